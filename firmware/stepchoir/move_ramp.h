// move_ramp.h: a move's speed profile (kMsgMove), pure integer arithmetic: the seed's
// Torricelli ramp, v^2 = v0^2 + 2as, up from speed_min at the first step, at most speed_max,
// and down again symmetrically to speed_min at the last step.
//
// The interval after a move's step k (k steps taken, `left` still to take) runs at
//   v = min(speed_max, sqrt(speed_min^2 + 2 * accel * n)),  n = min(k - 1, left - 1),
// in steps/s, so the first and the last interval run at speed_min. No division at run time
// but the one that turns a speed into a period.
//
// Who calls it: the firmware's main loop (moves.cpp), once a step; the host tests
// (tests/firmware/test_motor.cpp). Budget: about 700 cycles on the AVR (a 16-step square root
// and a 32-bit division), under 5 % of the main loop at the fastest move (5,000 steps/s).
#ifndef STEPCHOIR_MOVE_RAMP_H
#define STEPCHOIR_MOVE_RAMP_H

#include <stdint.h>

#include "src/stepchoir_protocol.h"

namespace ramp {

struct Ramp {
  uint32_t v0_sq;         // speed_min^2, (steps/s)^2
  uint32_t two_accel;     // 2 * accel, steps/s^2
  uint32_t cruise_steps;  // from this n on, speed_max
  uint16_t speed_min, speed_max;
};

// Square root, rounded down, of a 32-bit number (bit by bit: 16 rounds, no multiply).
inline uint16_t isqrt(uint32_t x) {
  uint32_t root = 0, bit = 1ul << 30;
  while (bit > x) bit >>= 2;
  while (bit != 0) {
    if (x >= root + bit) {
      x -= root + bit;
      root = (root >> 1) + bit;
    } else {
      root >>= 1;
    }
    bit >>= 2;
  }
  return (uint16_t)root;
}

// The ramp of a move the caller checked: speeds kMoveSpeedMin <= speed_min <= speed_max <=
// kMoveSpeedMax, 1 <= accel <= kMoveAccelMax (so no product below overflows 32 bits).
inline Ramp make(uint16_t speed_min, uint16_t speed_max, uint32_t accel) {
  Ramp r;
  r.v0_sq = (uint32_t)speed_min * speed_min;
  r.two_accel = 2 * accel;
  const uint32_t span = (uint32_t)speed_max * speed_max - r.v0_sq;
  r.cruise_steps = (span + r.two_accel - 1) / r.two_accel;
  r.speed_min = speed_min;
  r.speed_max = speed_max;
  return r;
}

// Speed (steps/s) of the interval after step `done` of a move with `left` steps still to take
// (done >= 1, left >= 1).
inline uint16_t speed(const Ramp &r, uint32_t done, uint32_t left) {
  const uint32_t n = (done < left ? done : left) - 1;
  if (n >= r.cruise_steps) return r.speed_max;  // (and 2an below stays under speed_max^2)
  const uint16_t v = isqrt(r.v0_sq + r.two_accel * n);
  return v < r.speed_min ? r.speed_min : v > r.speed_max ? r.speed_max : v;
}

// The period (ticks q8) of a speed in steps/s on a board of f_cpu_hz (at most 16 MHz: the
// dividend must fit 32 bits).
inline uint32_t period_q8(uint16_t steps_per_s, uint32_t f_cpu_hz) { return (f_cpu_hz << 8) / steps_per_s; }

}  // namespace ramp

#endif  // STEPCHOIR_MOVE_RAMP_H

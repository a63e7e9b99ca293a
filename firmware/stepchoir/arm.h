// arm.h: arming motor m's compare channel for its next edge (arm<M>), and the match count its
// entry stub keeps while that edge is a timer wrap or more away (g_wraps, g_wraps_then).
// Included by the step path's one translation unit (scheduler.cpp): its handlers (serve) and
// channel operations (poke; start, through arm_m) call arm<M>, and its stubs (chip/stub.h) count
// off g_wraps. A header so that the handlers inline arm<M>. AVR only. How an edge is made:
// scheduler.h.
#ifndef STEPCHOIR_ARM_H
#define STEPCHOIR_ARM_H

#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>
#include <util/atomic.h>

#include "boards/board.h"
#include "chip/channel.h"
#include "config.h"
#include "scheduler.h"

namespace sched {
namespace {

// Matches of motor m's channel still to come before its edge (its stub counts them down and
// clears bit m of GPIOR0 at the last); kWrapsVisit: the next match enters the handler (a
// command to take, or more matches than the count holds).
volatile uint8_t g_wraps[board::active::kMotorCount];
const uint8_t kWrapsVisit = 0x80;
// g_wraps once the count is out: 0 (the edge next) or kWrapsVisit.
volatile uint8_t g_wraps_then[board::active::kMotorCount];
const uint16_t kFineTicks = 61440;       // arm() counts wraps exactly up to this far ahead
const uint8_t kRoughSpareWraps = 16;     // ... and further, ends a rough count this early
const uint8_t kRoughVisit = 0xFF;        // arm(): the handler at the next match

// Arms channel m for the edge at board time d and clears its busy bit. Returns false when d is
// too close to be sure the compare fires (the caller raises the edge itself, still busy). When
// d is a timer wrap or more away, bit m of GPIOR0 and g_wraps make the stub count the matches
// before it instead of raising. Called from: the motor's own context (its handler, or the main
// loop while the motor is silent), busy. Interrupts off about 20 cycles at a time (the compare's
// write longer while a sibling compare due within kSettleTicks sets its flag).
template <uint8_t M> __attribute__((always_inline)) inline bool arm(uint32_t d) {
  typedef Chan<M> C;
  const int32_t est = (int32_t)(d - now());
  if (est <= (int32_t)cfg::kArmGuardTicks) return false;
  const typename C::Value v = C::value(d);
  if (C::read() != v) {  // a new value (an unchanged one, at a visit, keeps its flag)
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      C::settle();
      C::write(v);
      // A flag now is the old value's (or a match of the new one just due: d then came, which
      // the check below finds): let it in while still busy, it returns at once. (The virtual
      // board takes a waiting interrupt two instructions after sei, and another channel's may
      // go first.)
      while (C::waiting()) {
        sei();
        __asm__ __volatile__("nop\n\tnop\n\tnop");
        cli();
      }
    }
  }
  // How many of the channel's matches come before d's own: its stub counts them down in
  // g_wraps (bit m of GPIOR0 set while any are left). Counted from the channel itself (the time
  // to its next match): Timer1 from est (half a 4 ms wrap covers the ISR being held
  // up since), Timer2 on the 16-bit timer from d; further than that reaches (kFineTicks), the
  // count is rough and ends kRoughSpareWraps early in the handler, which counts again. The
  // timer is read with interrupts off and the count worked out and set with them on (the stub
  // reads it only once the busy bit is clear); the busy bit is cleared, with interrupts off,
  // only if the channel's next match is still ahead then (none came since the read).
  const uint16_t d16 = (uint16_t)d;
  // rough: the matches to count before the handler's next visit (after them, the next match
  // enters it: kRoughVisit for that one at once); 0: an exact count.
  uint8_t rough = 0;
  if (C::kWrap < 65536ul && est >= (int32_t)kFineTicks) {
    const uint32_t wraps = (uint32_t)est / C::kWrap;  // at most one more comes before d's
    rough = wraps > kRoughSpareWraps + 63u ? 63 : wraps > kRoughSpareWraps + 1u ? (uint8_t)(wraps - kRoughSpareWraps) : kRoughVisit;
  }
  const bool check_left = est < 32768;
  const uint32_t half_on = (uint32_t)est + C::kWrap / 2;
  for (;;) {
    // The timers are read together with interrupts off (6-10 cycles: Timer1 alone, or with
    // Timer2 or Timer3); the time to the next match is worked out after, from what was read.
    uint16_t t;
    typename C::Snap snap;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      t = TCNT1;
      snap = C::snap();
    }
    const uint16_t u = C::until(t, snap);
    const uint8_t n = rough ? 0xFF : C::count(half_on, d16, t, u);
    // The stub reads g_wraps and its visit bit only once the busy bit is clear: they are set
    // with interrupts on.
    // d came, or comes too soon to be sure of its match (it may come while busy, and return)
    if ((check_left && (int16_t)(d16 - t) <= (int16_t)cfg::kArmGuardTicks) || (n == 0 && u <= cfg::kArmGuardTicks)) {
      g_wraps[M] = kWrapsVisit;  // a match of it only visits
      GPIOR0 |= _BV(M);
      return false;
    }
    if (rough) {
      g_wraps[M] = rough == kRoughVisit ? kWrapsVisit : rough;
      g_wraps_then[M] = kWrapsVisit;
      GPIOR0 |= _BV(M);
    } else if (n == 0) {
      GPIOR0 &= (uint8_t)~_BV(M);
    } else {
      g_wraps[M] = n;
      g_wraps_then[M] = 0;
      GPIOR0 |= _BV(M);
    }
    // The channel is freed if its next match (u after the read) is still kArmFinalTicks away:
    // none came since the read, and none comes before the busy bit is clear. (A match due
    // sooner comes while busy and returns, and the count starts again from the one after.)
    if (u <= cfg::kArmFinalTicks) continue;
    const uint16_t window = (uint16_t)(u - cfg::kArmFinalTicks);
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      if ((uint16_t)(TCNT1 - t) < window) {
        busy_clear<M>();
        return true;
      }
    }
  }
}

}  // namespace
}  // namespace sched

#endif  // STEPCHOIR_ARM_H

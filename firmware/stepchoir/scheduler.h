// scheduler.h: the step ISR. Every motor steps at its own period from one 16-bit timer
// (Timer1, no prescaler: 1 tick = 1 CPU cycle = 62.5 ns at 16 MHz).
//
// Deadlines are absolute: next edge = previous scheduled edge + period, with the period's
// 8 fractional bits carried, so each motor's average frequency is exact to the crystal.
//
//   deadline(k+1) = deadline(k) + period_q8 / 256      (32-bit ticks + 8-bit fraction)
//
//            |<-- burst: raised at their own ticks -->|<- pulse ->|  bookkeeping (I=1)
//   STEP x   ____|‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|______________________
//   STEP y   _____________|‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|______________________
//            ^ OCR1A match                                       ^ lower, sei(), advance, sort
//
// The ISR raises every motor due within cfg::kChainTicks of the match, each at its own tick,
// holds the pulse, lowers them, then does the bookkeeping (position, endstops, soft limits,
// next deadline, sorted order) with interrupts enabled so the UART is never starved.
// Measured on the virtual board: see docs/ARCHITECTURE.md and bench/results.
#ifndef STEPCHOIR_SCHEDULER_H
#define STEPCHOIR_SCHEDULER_H

#include <stdint.h>

#include "boards/pins.h"
#include "src/stepchoir_protocol.h"

namespace sched {

// Static wiring of one motor, from the board table.
struct Wiring {
  board::Pin step, dir, min_switch, max_switch;
};

// Motion settings of one motor (from kMsgConfig).
struct Motion {
  uint32_t travel_steps;      // 0 = no soft limits
  uint16_t pulse_ticks;       // STEP high time
  bool switch_active_high;
  uint32_t start_period_q8;   // onset ramp start (0 = none)
  uint32_t ramp_q8;           // period shrink per step during the ramp
};

// Called from: setup(). Sets Timer1 running, pins as outputs, carriages at mid travel.
void init(uint8_t motor_count, const Wiring *wiring);

// Called from: main loop. Replaces one motor's motion settings.
void set_motion(uint8_t m, const Motion &motion);

// Called from: main loop. Silences every motor at once.
void silence_all();

// Called from: main loop. True when motor m is stepping.
bool sounding(uint8_t m);

}  // namespace sched

#endif  // STEPCHOIR_SCHEDULER_H

// scheduler.h: the step ISR. Every motor steps at its own period from one 16-bit timer
// (Timer1, no prescaler: 1 tick = 1 CPU cycle = 62.5 ns at 16 MHz).
//
// Deadlines are absolute: next edge = previous scheduled edge + period, with the period's
// 8 fractional bits carried, so each motor's average frequency is exact to the crystal.
//
//   deadline(k+1) = deadline(k) + period_q8 / 256      (32-bit ticks + 8-bit fraction)
//
//   OCR1A match (kEarlyTicks before the deadline): prologue and waiting with interrupts on
//            | cli kCliLeadTicks before the edge
//            v        v deadline: raise       v pulse over: lower, sei()
//   STEP x   _________|‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|_____________________________________
//   STEP y   ______________|‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|_____  (due within kChainTicks: same burst)
//                                              then, one motor at a time with interrupts on:
//                                              position, endstops, soft limits, ramp,
//                                              deadline += period, sorted insert
//
// Every raise waits for its own deadline tick, whichever way the ISR got there, so edges
// carry no entry-latency jitter. Between two motors' bookkeeping the ISR checks whether the
// next edge is due within kSoonTicks and plays it first. Measured on the virtual board: see
// docs/ARCHITECTURE.md and bench/results.
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

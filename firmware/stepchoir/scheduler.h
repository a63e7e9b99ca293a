// scheduler.h: the step ISR. Every motor steps at its own period from one 16-bit timer
// (Timer1, no prescaler: 1 tick = 1 CPU cycle = 62.5 ns at 16 MHz).
//
// Deadlines are absolute: next edge = previous scheduled edge + period, with the period's
// 8 fractional bits carried, so each motor's average frequency is exact to the crystal.
//
//   deadline(k+1) = deadline(k) + period_q8 / 256      (32-bit ticks + 8-bit fraction)
//
// The compare unit fires kEarlyTicks before the earliest deadline. The ISR masks itself and
// runs with interrupts on; it turns them off only from kCliLeadTicks before an edge until the
// STEP pin is raised, so every edge lands on its tick whichever way the ISR got there:
//
//   OCR1A match      cli          raise             lower (pulse over)
//   |--- I on -------|-- I off ---|------ I on -----|
//   STEP  ____________________________|‾‾‾‾‾‾‾‾‾‾‾‾‾‾|________________________
//
// Motors due within kComebackTicks of the previous edge are played in the same burst, whose
// raise times are planned before its first wait: edges closer than kWriteGapTicks (one pass of
// the raise loop) share the difference, and raises close together run with interrupts off
// from the first to the last, letting waiting interrupts in between them when they are
// further apart than kCliLeadTicks (kBreatherTicks). Between
// bursts the ISR does its other work in small pieces, each only when no edge is due within
// kSoonTicks: a played motor's next deadline and sorted place, a step's position and endstop
// bookkeeping (bounce-back, soft limits), a command the main loop left in a motor's mailbox,
// a timestamped entry from the queue (hal::queue_at), taken 3 ms before its time so that it
// starts or strikes its motor on the tick whatever the main loop is doing.
// The main loop never touches the order itself: its critical sections stay short. It starts
// a silent motor itself when no edge is near (its first edge raised at once, the motor left to
// the ISR's bookkeeping), so that a live note's onset is not held up by the ISR's hand-over. When the
// ISR has kept it from beginning a pass for 8 ms, taking 3/4 of the CPU, the ISR leaves it
// slices (cfg::kMaxIsrTicks, kMaxInvocationTicks, kMainSliceTicks) and its edges fall late
// instead.
// Measured on the virtual board: bench/results/pitch-<board>.md.
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

// Called from: main loop, at the start of every pass. Tells the step ISR the main loop runs
// (its overload guard leaves it slices when it has not for 8 ms).
void main_loop_alive();

// Called from: main loop, every pass. Defence in depth: if the step ISR's compare is long
// overdue (a compare armed closer than arm()'s own write-then-clear sequence is erased by the
// clear: cfg::kMinLeadTicks), arms it again at once instead of waiting for the 16-bit timer to
// come round (4 ms).
void rescue_missed_compare();

// Called from: main loop. Silences every motor at once.
void silence_all();

}  // namespace sched

#endif  // STEPCHOIR_SCHEDULER_H

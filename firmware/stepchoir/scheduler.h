// scheduler.h: motors step from timer compare channels, one channel per motor (Timer1 A/B
// and Timer2 A/B on the Uno, Timer1 A/B/C and Timer3 A/B on the Mega); board time is Timer1,
// counting CPU cycles (1 tick = 62.5 ns at 16 MHz), extended to 32 bits from a base that
// Timer0's compare moves on.
//
// Deadlines are absolute: next edge = previous scheduled edge + period, with the period's
// 8 fractional bits carried, so each motor's average frequency is exact to the crystal.
//
//   deadline(k+1) = deadline(k) + period_q8 / 256      (32-bit ticks + 8-bit fraction)
//
// A channel's compare fires on its motor's deadline. Its ISR is a stub that raises STEP as its
// third instruction and jumps to the motor's handler, which turns interrupts back on at once:
//
//   match   raise (13 cycles on)  sei      lower (pulse over)   bookkeeping, next compare armed
//   |-------|---------------------|--- I on: other motors' ISRs nest in the handler ---|
//   STEP  _________|‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|________________________________________
//
// So an edge is late only by what keeps interrupts off when it is due: another stub (19
// cycles; 29 when it counts off a match, 37 at the last), the receive ISR (14 cycles at entry,
// 15 a byte, 8 and 7 at exit), a critical section of the main loop or a handler (about 20
// cycles; about 50 when the main loop writes a live note's compare, fire).
// The handler lowers STEP once the pulse is over, then does the step's bookkeeping (position,
// endstops, soft limits, reversal), takes a command from the motor's mailbox, works out the
// next deadline and arms the compare. The matches a long period's deadline is a timer wrap or
// more away from are counted off by the stub (bit m of GPIOR0 set while any are left). The
// main loop starts a silent motor itself (its channel is busy: every match returns at once);
// a sounding motor's command goes to its mailbox, and the main loop brings its ISR for it
// (poke). Timestamped entries are taken by the main loop (poll) kTakeTicks before their time
// and strike their motor on the tick.
// Measured on the virtual board: bench/results/pitch-<board>.md, docs/ARCHITECTURE.md.
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

// Called from: anywhere. Board time in ticks (CPU cycles since the step timer started, about
// 1 ms after reset), wrapping at 2^32: Timer1's count extended to 32 bits. Interrupts off for
// about 14 cycles.
uint32_t now();

// Called from: setup(). Sets Timer1 running, pins as outputs, carriages at mid travel.
void init(uint8_t motor_count, const Wiring *wiring);

// Called from: main loop. Replaces one motor's motion settings.
void set_motion(uint8_t m, const Motion &motion);

// Called from: main loop, every pass. Takes the timestamped entries due within kTakeTicks.
void poll();

// Called from: main loop. Silences every motor at once and empties the timed queue.
void silence_all();

// Called from: main loop (kMsgSilence). Silences the motors whose bit is set in mask at once
// (a move among them ends, stopped) and drops their timed entries; the others play on.
void silence(uint8_t mask);

// Called from: main loop. Motor m plays period_q8 (ticks q8; sc::kPeriodSilent = silence) from
// now on, keeping the phase of a sounding motor. The caller checked the range and woke the
// driver.
void set_period(uint8_t m, uint32_t period_q8);

// Called from: main loop. Motor m takes period_q8 exactly at board time at_ticks, as a timed
// entry does (a silent motor's first edge falls on it, a sounding one strikes on it); from
// now on when at_ticks is less than cfg::kStartLeadTicks ahead. The caller woke the driver.
void set_period_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks);

// Called from: main loop. Bit m set while motor m sounds (its channel belongs to its ISR).
uint8_t sounding();

// Moves (kMsgMove; moves.cpp drives them). Called from: main loop.
// start_move: silent motor m steps `steps` times in direction up, its first edge at `at` (or
// cfg::kStartLeadTicks from now when sooner), at period_q8 until retune_move changes it; with
// sc::kMoveToSwitch in move_flags it ends at the first step that finds the switch ahead pressed
// (with no step when it reads pressed already). No bounce-back or soft limits meanwhile. False
// (nothing done) when the motor sounds.
bool start_move(uint8_t m, bool up, uint32_t steps, uint8_t move_flags, uint32_t period_q8, uint32_t at);
// retune_move: a moving motor's period from its next step on (phase kept); nothing once the move
// ended (it never starts a motor).
void retune_move(uint8_t m, uint32_t period_q8);
// move_state: true while motor m moves, with the steps it has still to take; false once its
// move ended (or it never moved), with how it ended (sc::MoveEnd) and the steps it did not take.
bool move_state(uint8_t m, uint32_t *left, uint8_t *end);
// set_position: motor m's counted position (steps) from now on.
void set_position(uint8_t m, int32_t position);

// Called from: main loop. The timed queue (timed_queue.h): entries in use, and one more (the
// caller checked queue_used() < cfg::kQueueSize; entries in time order).
uint8_t queue_used();
void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks);

// What the step path counted since power-up or reset_counters(), for the status reply (each
// motor's reversals: motor_status).
struct Counters {
  uint16_t late_edges;    // edges a handler raised itself (its compare armed too late)
  uint8_t motor_fault;    // sc::ErrorCode of the last stuck switch, 0 if none
  uint8_t late_entries;   // timed entries made after their time (wrapping; not reset)
  uint8_t late_motor;     // the last one's motor
};
// Called from: main loop. A consistent copy (interrupts off for about 20 cycles).
Counters counters();
// Called from: main loop. Zeroes every motor's reversals, late_edges and motor_fault.
void reset_counters();

// Called from: main loop. Motor m's position, direction, sounding and fault flags, and its
// reversals (interrupts off for about 30 cycles).
void motor_status(uint8_t m, sc::StatusMotor *out);

}  // namespace sched

#endif  // STEPCHOIR_SCHEDULER_H

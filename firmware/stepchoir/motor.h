// motor.h: one motor's step logic, pure: step accounting with endstop bounce-back, switch
// chatter and stuck-switch handling, soft limits, deadlines with the period's fraction carried,
// the onset ramp, timed strikes (restrike), and how a command changes a motor.
//
// No timer, no interrupt vector: a switch is a byte read through a pointer, board time comes
// from sched::now(). The AVR build includes this header in its one step-path translation unit
// (scheduler.cpp), so that the handlers inline it; the host tests include it with a fake clock
// and fake port bytes (tests/firmware/test_motor.cpp).
//
// Who runs it: motor m's own context, which is its channel's handler (interrupts on) while it
// sounds, or the main loop while it is silent. Nothing else touches a motor meanwhile.
//
//   deadline(k+1) = deadline(k) + period_q8 / 256      (32-bit ticks + 8-bit fraction)
#ifndef STEPCHOIR_MOTOR_H
#define STEPCHOIR_MOTOR_H

#include <stdint.h>

#include "config.h"
#include "microstep.h"
#include "src/stepchoir_protocol.h"

#if defined(__AVR__)
#include <util/atomic.h>
// A read-modify-write of a port other motors share, or of what an ISR also reads.
#define SC_ATOMIC ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
#define SC_INLINE __attribute__((always_inline)) inline
#else
#define SC_ATOMIC
#define SC_INLINE inline
#endif

namespace sched {

// Board time in ticks (CPU cycles), wrapping at 2^32. AVR: Timer1 extended (scheduler.cpp);
// host tests: their fake clock.
uint32_t now();

namespace {

// Motor flags.
const uint8_t kUp = 0x01;          // DIR pin high: position counts up
const uint8_t kArmed = 0x02;       // the endstop may trigger a reversal
const uint8_t kActiveHigh = 0x04;  // switches read HIGH when pressed
const uint8_t kRamp = 0x08;        // onset ramp in progress
const uint8_t kFault = 0x10;       // switch found stuck: ignored from now on
const uint8_t kLimits = 0x20;      // soft limits on (travel configured)
const uint8_t kRestrike = 0x40;    // a timed note change waits for its time (restrike_at)
const uint8_t kMove = 0x80;        // a move (kMsgMove) in progress: account_move counts its steps

// Mailbox states (Motor::cmd).
const uint8_t kCmdNone = 0;
const uint8_t kCmdLive = 1;   // play cmd_period_q8 from now on
const uint8_t kCmdTimed = 2;  // ... exactly at cmd_at

// A timed strike on a sounding motor replaces an old edge due this much or less before its
// time (ticks): both would sound as one doubled step (a note change on the old note's own grid, as
// in a legato melody, lands within a tick of an old edge).
const int32_t kStrikeSnapTicks = 512;

struct Motor {
  uint32_t deadline;          // ticks of the next STEP rising edge (of the one just raised, in its ISR)
  uint32_t period_q8;         // current period, ticks q8 (0 = silent)
  uint8_t deadline_frac;      // 1/256 tick
  uint8_t flags;
  uint8_t pulse_ticks;        // STEP high time (at most 160: 10 us)
  volatile uint8_t *dir_port;
  volatile uint8_t *sw_up_pin;    // switch checked while moving up (max), 0 if none
  volatile uint8_t *sw_down_pin;  // switch checked while moving down (min), 0 if none
  uint8_t dir_mask, sw_up_mask, sw_down_mask;
  int32_t position;           // steps
  int32_t limit_hi, limit_lo; // soft limits, steps
  uint32_t travel_steps;
  uint32_t target_q8;         // ramp target period, or the period a restrike switches to
  uint32_t ramp_q8;           // ramp: period shrink per step
  uint32_t start_q8;          // ramp: first period (0 = no ramp)
  uint32_t released_since;    // ticks: the switch has read released since then
  uint32_t restrike_at;       // ticks: when a timed note change on a sounding motor strikes
  uint16_t pressed_steps;     // steps taken while the switch still reads pressed
  int32_t calibration_steps;  // how far the last switch press moved the counted position
  // Mailbox of a sounding motor: the main loop fills cmd_period_q8 and cmd_at while cmd is
  // kCmdNone, then sets cmd with interrupts off; the motor's channel ISR takes it.
  uint32_t cmd_period_q8;
  uint32_t cmd_at;
  volatile uint8_t cmd;
  // A move (kMove): steps still to take, sc::kMoveToSwitch or 0, and how it ended (sc::MoveEnd,
  // written when kMove is cleared).
  uint32_t move_left;
  uint8_t move_flags;
  uint8_t move_end;
  // Reversals at a switch or a soft limit since the counters were reset, wrapping at 65536 (the
  // status reply's StatusMotor::reversals): account_step counts, the main loop reads and zeroes.
  uint16_t reversals;
};

// What the motors' logic counts for the status reply; the step path's ISRs write it. Each
// motor counts its own reversals (Motor::reversals).
struct StepCounters {
  volatile uint16_t late_edges;     // edges a handler raised itself (its compare armed too late)
  volatile uint8_t motor_fault;     // sc::ErrorCode of the last stuck switch, 0 if none
  volatile uint8_t late_entries;    // timed entries made after their time (played at once)
  volatile uint8_t late_motor;      // the last one's motor
};
StepCounters g_count;

// Ends m's move with its motor silent (the handler then frees the channel); a command in the
// mailbox is dropped, so the main loop's last speed change cannot start the motor again.
SC_INLINE void end_move(Motor &m, uint8_t end) {
  m.move_end = end;
  m.period_q8 = 0;
  m.flags &= (uint8_t)~(kMove | kRamp | kRestrike);
  m.cmd = kCmdNone;
}

// True when the switch m meets going up (or down) reads pressed; false without one.
bool pressed_ahead(const Motor &m, bool up) {
  volatile uint8_t *sw = up ? m.sw_up_pin : m.sw_down_pin;
  return sw && drv::switch_pressed((*sw & (up ? m.sw_up_mask : m.sw_down_mask)) != 0, m.flags & kActiveHigh);
}

// One step of a move: position counted; the move ends after its last step or, toward a
// switch, at the first step that finds the switch ahead pressed. No bounce-back, no soft
// limits: the carriage may be anywhere. Budget: as account_step's.
__attribute__((noinline)) void account_move(Motor &m) {
  const bool up = m.flags & kUp;
  m.position += up ? 1 : -1;
  --m.move_left;
  if ((m.move_flags & sc::kMoveToSwitch) && pressed_ahead(m, up))
    end_move(m, sc::kMoveEndSwitch);
  else if (m.move_left == 0)
    end_move(m, sc::kMoveEndSteps);
}

// Position, endstop bounce-back and soft limits after one step of m; a reversal turns DIR
// before the motor's next step (a move's step: account_move). Budget: part of the handler's
// bookkeeping (tens of cycles).
SC_INLINE void account_step(Motor &m) {
  if (m.flags & kMove) {
    account_move(m);
    return;
  }
  const bool up = m.flags & kUp;
  m.position += up ? 1 : -1;
  bool reverse = false;
  volatile uint8_t *sw = up ? m.sw_up_pin : m.sw_down_pin;
  if (sw) {
    const uint8_t mask = up ? m.sw_up_mask : m.sw_down_mask;
    if (drv::switch_pressed((*sw & mask) != 0, m.flags & kActiveHigh)) {
      if (m.flags & kArmed) {
        reverse = true;
        m.flags &= (uint8_t)~kArmed;
        m.pressed_steps = 0;
        m.calibration_steps = 0;
        if (m.flags & kLimits) {  // the switch marks the end: count from there
          const int32_t end = up ? (int32_t)m.travel_steps : 0;
          m.calibration_steps = end - m.position;
          m.position = end;
        }
      } else if (++m.pressed_steps > cfg::kStuckSteps) {
        // Still pressed this far from where it fired: the switch is stuck, and that press did
        // not mark an end. Ignore the switch and undo the position it set.
        m.flags |= kFault;
        m.sw_up_pin = 0;
        m.sw_down_pin = 0;
        m.position -= m.calibration_steps;
        g_count.motor_fault = sc::kErrEndstopStuck;
      }
      m.released_since = m.deadline;
    } else if (!(m.flags & kArmed) && m.deadline - m.released_since > cfg::kRearmTicks) {
      m.flags |= kArmed;
      m.pressed_steps = 0;
    }
  }
  if (!reverse && (m.flags & kLimits)) reverse = up ? m.position >= m.limit_hi : m.position <= m.limit_lo;
  if (reverse) {
    m.flags ^= kUp;
    SC_ATOMIC { *m.dir_port ^= m.dir_mask; }  // other motors share the port
    m.reversals = (uint16_t)(m.reversals + 1);  // wraps: one 16-bit increment, no test
  }
}

// Next deadline of m after the step at m.deadline: one period on (fraction carried), the
// onset ramp shortening the period step by step; a pending restrike lands exactly on its time
// instead, with the new period from there (0: a timed silence, before its first edge at or
// after the time).
SC_INLINE void next_deadline(Motor &m) {
  if (m.flags & kRamp) {
    if (m.period_q8 > m.target_q8 + m.ramp_q8) {
      m.period_q8 -= m.ramp_q8;
    } else {
      m.period_q8 = m.target_q8;
      m.flags &= (uint8_t)~kRamp;
    }
  }
  const uint16_t frac = (uint16_t)m.deadline_frac + (uint8_t)m.period_q8;
  const uint32_t next = m.deadline + (m.period_q8 >> 8) + (frac >> 8);
  if ((m.flags & kRestrike) &&
      (int32_t)(next - m.restrike_at) >= (m.target_q8 ? -kStrikeSnapTicks : 0)) {
    m.deadline = m.restrike_at;
    m.deadline_frac = 0;
    m.period_q8 = m.target_q8;
    m.flags &= (uint8_t)~kRestrike;
    return;
  }
  m.deadline_frac = (uint8_t)frac;
  m.deadline = next;
}

// Which way a silent motor starts: the direction with more room ahead (the music2gcode border
// rule), never into a pressed switch.
bool start_up(const Motor &m) {
  bool up = m.flags & kUp;
  if (m.flags & kLimits) up = m.position < (int32_t)(m.travel_steps / 2);
  volatile uint8_t *sw = up ? m.sw_up_pin : m.sw_down_pin;
  const uint8_t mask = up ? m.sw_up_mask : m.sw_down_mask;
  // A pressed switch ahead turns it round, unless it is one input for both ends (then it says
  // nothing about which end the carriage is at: the position decides). Two switches may sit
  // on one port (the Mega's min and max): the same register with another bit is another input.
  const bool one_input = m.sw_up_pin == m.sw_down_pin && m.sw_up_mask == m.sw_down_mask;
  if (sw && !one_input && drv::switch_pressed((*sw & mask) != 0, m.flags & kActiveHigh)) up = !up;
  return up;
}

// Sets DIR (other motors share the port: the write runs with interrupts off).
void set_dir(Motor &m, bool up) {
  if (up == (bool)(m.flags & kUp) && ((*m.dir_port & m.dir_mask) != 0) == up) return;
  if (up) m.flags |= kUp;
  else m.flags &= (uint8_t)~kUp;
  SC_ATOMIC {
    if (up) *m.dir_port |= m.dir_mask;
    else *m.dir_port &= (uint8_t)~m.dir_mask;
  }
}

// A silent motor's period from its first edge on: the onset ramp's start period when longer.
void start_period(Motor &m, uint32_t period_q8) {
  m.deadline_frac = 0;
  m.flags &= (uint8_t)~(kRamp | kRestrike);
  if (m.start_q8 > period_q8) {
    m.period_q8 = m.start_q8;
    m.target_q8 = period_q8;
    m.flags |= kRamp;
  } else {
    m.period_q8 = period_q8;
  }
}

// A silent motor starts at period (not silence): DIR by the border rule, its first edge at
// `first` (a live note's is set by fire() in scheduler.cpp), and the onset ramp. The caller hands
// the motor to its channel.
inline void start_silent(Motor &m, uint32_t period, uint32_t first) {
  set_dir(m, start_up(m));
  m.deadline = first;
  start_period(m, period);
}

// Motor m takes period (sc::kPeriodSilent: silence) now, or, timed, exactly at board time
// `at`: a silent motor starts (its first edge on the time, or kStartLeadTicks from now), a
// sounding one keeps its phase (the next edge one new period after the last), or strikes on
// the time. Returns false when a timed change came too late for its time (made at once).
// m.deadline is the next edge still to come.
bool apply(Motor &m, uint32_t period, bool want_timed, uint32_t at) {
  const uint32_t soonest = now() + cfg::kStartLeadTicks;
  const bool timed = want_timed && (int32_t)(at - soonest) > 0;
  if (m.period_q8 == 0 && period == sc::kPeriodSilent) {
    m.flags &= (uint8_t)~(kRamp | kRestrike);  // silent already (a timed silence may be pending)
  } else if (period == sc::kPeriodSilent && (!timed || (int32_t)(m.deadline - at) >= 0)) {
    // Now, or at a time before the motor's next edge (which would be the first one silenced).
    m.period_q8 = 0;
    m.flags &= (uint8_t)~(kRamp | kRestrike);
  } else if (m.period_q8 == 0) {
    start_silent(m, period, timed ? at : soonest);
  } else if (!timed) {
    m.flags &= (uint8_t)~(kRamp | kRestrike);
    if (m.period_q8 != period) {
      uint16_t frac = (uint16_t)m.deadline_frac - (uint8_t)m.period_q8;
      const uint32_t last = m.deadline - (m.period_q8 >> 8) - ((frac >> 8) ? 1 : 0);
      frac = (uint16_t)(uint8_t)frac + (uint8_t)period;
      uint32_t next = last + (period >> 8) + (frac >> 8);
      if ((int32_t)(next - soonest) < 0) {
        next = soonest;
        frac = 0;
      }
      m.deadline = next;
      m.deadline_frac = (uint8_t)frac;
      m.period_q8 = period;
    }
  } else if (period != sc::kPeriodSilent && (int32_t)(m.deadline - at) >= -kStrikeSnapTicks) {
    // The next edge not before the time, or just before it: strike on it. (A timed silence
    // lets an edge due before its time sound: it waits as a pending change, below.)
    m.deadline = at;
    m.deadline_frac = 0;
    m.period_q8 = period;
    m.flags &= (uint8_t)~(kRamp | kRestrike);
  } else {  // strike (or fall silent) on the time, after the edges still due before it
    m.target_q8 = period;
    m.restrike_at = at;
    m.flags = (uint8_t)((m.flags & ~kRamp) | kRestrike);
  }
  return timed || !want_timed;
}

// Takes the command in m's mailbox (motor mi); counts it when a timed one came too late.
void take_command(uint8_t mi, Motor &m) {
  const bool timed = m.cmd == kCmdTimed;
  m.cmd = kCmdNone;
  if (!apply(m, m.cmd_period_q8, timed, m.cmd_at)) {
    g_count.late_motor = mi;
    g_count.late_entries = (uint8_t)(g_count.late_entries + 1);
  }
}

}  // namespace
}  // namespace sched

#endif  // STEPCHOIR_MOTOR_H

// scheduler.cpp: the step ISR and the motor table it works on (AVR only).
#include "scheduler.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "boards/board.h"
#include "config.h"
#include "hal.h"
#include "link.h"
#include "microstep.h"
#include "pin_io.h"
#include "step_driver.h"

namespace sched {
namespace {

// Motor flags.
const uint8_t kUp = 0x01;          // DIR pin high: position counts up
const uint8_t kArmed = 0x02;       // the endstop may trigger a reversal
const uint8_t kActiveHigh = 0x04;  // switches read HIGH when pressed
const uint8_t kRamp = 0x08;        // onset ramp in progress
const uint8_t kFault = 0x10;       // switch found stuck: ignored from now on
const uint8_t kLimits = 0x20;      // soft limits on (travel configured)
const uint8_t kRestrike = 0x40;    // a timed note change waits for its time (restrike_at)

struct Motor {
  uint32_t deadline;          // ticks of the next STEP rising edge (of the last one while played)
  uint32_t period_q8;         // current period, ticks q8 (0 = silent)
  uint8_t deadline_frac;      // 1/256 tick
  uint8_t flags;
  uint16_t pulse_ticks;
  volatile uint8_t *step_port;
  volatile uint8_t *dir_port;
  volatile uint8_t *sw_up_pin;    // switch checked while moving up (max), 0 if none
  volatile uint8_t *sw_down_pin;  // switch checked while moving down (min), 0 if none
  uint8_t step_mask, dir_mask, sw_up_mask, sw_down_mask;
  int32_t position;           // steps
  int32_t limit_hi, limit_lo; // soft limits, steps
  uint32_t travel_steps;
  uint32_t target_q8;         // ramp target period, or the period a restrike switches to
  uint32_t ramp_q8;           // ramp: period shrink per step
  uint32_t start_q8;          // ramp: first period (0 = no ramp)
  uint32_t released_since;    // ticks: the switch has read released since then
  uint32_t restrike_at;       // ticks: when a timed note change on a sounding motor strikes
  uint32_t next_rough;        // played, not yet bookkept: about when its next edge is due
  uint16_t pressed_steps;     // steps taken while the switch still reads pressed
  int32_t calibration_steps;  // how far the last switch press moved the counted position
  // Mailbox, written by the main loop with interrupts off, read by the step ISR (bit m of
  // g_cmd_mask says it holds a period).
  uint32_t cmd_period_q8;
};

Motor g_motor[board::active::kMotorCount];
uint8_t g_count;
Motor *g_order[board::active::kMotorCount];            // sounding motors not yet played, earliest deadline first
volatile uint8_t g_active;     // how many of g_order are valid
Motor *g_played[board::active::kMotorCount];           // motors stepped by a burst, waiting for their next deadline
uint8_t g_played_count;
volatile uint8_t g_cmd_mask;   // bit m: motor m has a command in its mailbox
uint8_t g_claimed;             // bit m: the main loop is starting motor m (start_now): hands off
uint32_t g_armed;              // 32-bit time OCR1A is armed for (always within 32768 ticks)
volatile uint16_t g_reversals;
volatile uint16_t g_late_edges;
volatile uint8_t g_motor_fault;
// Timestamped entries (kMsgAt): a ring the main loop fills and the step ISR empties, each
// entry cfg::kTakeTicks before its time, so that it starts or strikes its motor exactly on
// the time whatever the main loop is busy with. One writer a side, no lock: the main loop
// writes a slot, then counts it in g_q_put; the ISR reads the oldest, then counts it in
// g_q_taken (free-running one-byte counts: used = put - taken).
struct AtSlot {
  uint32_t at;
  uint32_t period_q8;
  uint8_t motor;
};
AtSlot g_q[cfg::kQueueSize];
volatile uint8_t g_q_put, g_q_taken;
uint8_t g_q_put_idx;   // main loop's next slot
uint8_t g_q_take_idx;  // step ISR's next slot (the main loop moves it only with interrupts off)
volatile uint8_t g_late_entries;  // entries taken after their time (played at once)
volatile uint8_t g_late_motor;    // the last one's motor
// Starvation of the main loop (see the ISR): board time when it last began a pass, and the
// ticks the step ISR has run since then (its invocations that returned).
volatile uint32_t g_main_pass;
uint32_t g_isr_busy;
const uint8_t kIsrEntryExitTicks = 160;  // the step ISR's prologue and epilogue, about
const uint8_t kRxIsrTicks = 56;          // one byte in the UART receive ISR, nested (simavr: 53)

// Called from: step ISR. Ticks of an invocation `in_isr` long that were its own: the receive
// ISR's bytes nested in it are the main loop's work (frames), not the steps'.
inline uint16_t own_ticks(uint16_t in_isr, uint8_t rx_entered) {
  const uint16_t rx = (uint16_t)((uint8_t)(link::rx_head() - rx_entered) & (cfg::kRxRingBytes - 1)) * kRxIsrTicks;
  return in_isr > rx ? (uint16_t)(in_isr - rx) : 0;
}
// Between two ISR invocations g_played and g_cmd_mask are empty unless the main loop just
// started a motor itself (start_now) or posted a command: the ISR returns only when it has
// nothing left to do, and the main loop wakes it for those within kPostLeadTicks.

const uint16_t kLateTicks = 36;  // an edge raised more than 2 us after its deadline is late (raise + 4)
// A timed strike on a sounding motor replaces an old edge due less than this before its time:
// both would sound as one doubled step (a note change on the old note's own grid, as in a
// legato melody, lands within a tick of an old edge). Far shorter than the command's hand-over
// lead, so the old edge is always still pending when the command comes.
const int32_t kStrikeSnapTicks = 512;

// Called from: step ISR. Inserts motor m by deadline.
void order_insert(Motor *m) {
  const uint32_t d = m->deadline;
  uint8_t pos = g_active;
  while (pos > 0 && (int32_t)(g_order[pos - 1]->deadline - d) > 0) {
    g_order[pos] = g_order[pos - 1];
    --pos;
  }
  g_order[pos] = m;
  g_active = (uint8_t)(g_active + 1);
}

// Called from: step ISR. Removes motor m if it is in the order.
void order_remove(Motor *m) {
  uint8_t n = g_active, i = 0;
  while (i < n && g_order[i] != m) ++i;
  if (i == n) return;
  for (; i + 1 < n; ++i) g_order[i] = g_order[i + 1];
  g_active = (uint8_t)(n - 1);
}

// Called from: step ISR and main loop, interrupts off. Current board time in ticks.
__attribute__((always_inline)) inline uint32_t now_locked() {
  return g_armed + (int16_t)(TCNT1 - (uint16_t)g_armed);
}

// A burst never runs into a played motor's own next step: it chains at most one edge of each
// motor, all within kBurstSpanTicks of the first, and the shortest period leaves
// kRescheduleTicks after that.
static_assert(cfg::kBurstSpanTicks + cfg::kRescheduleTicks <= (sc::kPeriodQ8Min >> sc::kPeriodFracBits),
              "a burst ends, and its motors are rescheduled, before the first one's next step");

// Called from: burst(), interrupts off. Waits for tick t (16-bit, with wrap), sets mask in
// *port and stores the time right after the write at *rp++. In assembly: as C the wait, write
// and store took 33 cycles of the raise loop's 59 (gcc kept the difference in extra registers
// and indexed the store), here 20, and the wait checks the timer every 8 cycles, not 11.
__attribute__((always_inline)) inline void raise_at(uint16_t t, volatile uint8_t *port, uint8_t mask, uint16_t *&rp) {
  uint16_t now;
  __asm__ __volatile__(
      "1:\n\t"
      "lds %A[now], %[tl]\n\t"
      "lds %B[now], %[th]\n\t"
      "sub %A[now], %A[t]\n\t"
      "sbc %B[now], %B[t]\n\t"
      "brmi 1b\n\t"
      "ld __tmp_reg__, %a[port]\n\t"
      "or __tmp_reg__, %[mask]\n\t"
      "st %a[port], __tmp_reg__\n\t"
      "lds %A[now], %[tl]\n\t"
      "lds %B[now], %[th]\n\t"
      "st %a[rp]+, %A[now]\n\t"
      "st %a[rp]+, %B[now]\n\t"
      : [now] "=&r"(now), [rp] "+x"(rp)
      : [t] "r"(t), [port] "z"(port), [mask] "r"(mask), [tl] "n"(_SFR_MEM_ADDR(TCNT1L)),
        [th] "n"(_SFR_MEM_ADDR(TCNT1H))
      : "memory");
}

// Called from: step ISR, interrupts on, the head due within kSoonTicks. Raises the head, then
// every next motor due within kComebackTicks of the previous edge (the ISR could not come back
// for it in time), lowering each STEP once its pulse has passed. Played motors move from
// g_order to g_played.
//
// The burst's raise times are planned before its first wait (16-bit, a few cycles a motor),
// so that going from one raise to the next is a tight loop (wait for the tick, write the
// port, note the time, load the next motor) of kWriteGapTicks:
// - an edge due less than kWriteGapTicks after the raise before it is planned kWriteGapTicks
//   after it, and a run of such forced raises is moved earlier by half its largest lateness
//   (never closer than kWriteGapTicks to the raise before the run): the error is shared, each
//   edge of two due on the same tick kWriteGapTicks / 2 off;
// - a raise closer than kCliLeadTicks to the one before, within kMaxOffTicks of its run's
//   first, is made in the same interrupts-off run; interrupts are off from kCliLeadTicks
//   before a run's first raise until its last;
// - a raise less than kBreatherTicks after the one before (but not in its run) stays in the
//   loop: waiting interrupts are let in (sei, nop, cli) right after the raise before, then
//   they are off until this one (a real AVR lets one in there; the virtual board none: it takes
//   a waiting interrupt two instructions after sei, `ctest -R vboard_timer_quirks`);
// - further apart, interrupts are on between runs, and pulses that have passed are lowered.
// Before the plan, a pass of the raise loop (loading the next motor, deciding its wait) took
// 90-130 cycles: an edge due that soon after another motor's raise came late.
// Cycles with interrupts off: at most kCliLeadTicks + kMaxOffTicks, or kBreatherTicks after a
// breath, plus one raise.
__attribute__((always_inline)) inline void burst() {
  const uint8_t active = g_active;
  uint16_t at[board::active::kMotorCount];  // planned raise times
  uint8_t n = 1;
  {
    const uint32_t first = g_order[0]->deadline;
    uint32_t last = first;
    at[0] = (uint16_t)last;
    for (; n < active; ++n) {
      const uint32_t d = g_order[n]->deadline;
      // the order is sorted: d - last >= 0
      if (d - last > cfg::kComebackTicks || d - first > cfg::kBurstSpanTicks) break;
      last = d;
      at[n] = (uint16_t)d;
    }
  }
  // Forced raises, and the runs made with interrupts off (see above). Bit i of joins: raise i
  // is made in the run of raise i - 1; of breathe: after letting waiting interrupts in.
  uint8_t joins = 0, breathe = 0;
  if (n > 1) {
    uint8_t run = 0;                          // first raise of the current forced run
    uint16_t run_late = 0;                    // its largest lateness
    uint16_t run_room = cfg::kWriteGapTicks;  // how far it may move earlier
    uint16_t prev = at[0];
    for (uint8_t i = 1; i <= n; ++i) {
      uint16_t gap = 0;
      if (i < n) {
        gap = (uint16_t)(at[i] - prev);
        if (gap < cfg::kWriteGapTicks) {
          const uint16_t late = (uint16_t)(cfg::kWriteGapTicks - gap);
          if (late > run_late) run_late = late;
          prev = at[i] = (uint16_t)(prev + cfg::kWriteGapTicks);
          continue;
        }
        prev = at[i];
      }
      if (run_late) {
        const uint16_t shift = (run_late >> 1) < run_room ? (uint16_t)(run_late >> 1) : run_room;
        for (uint8_t k = run; k < i; ++k) at[k] = (uint16_t)(at[k] - shift);
        run_late = 0;
      }
      if (i == n) break;
      run = i;
      run_room = (uint16_t)(gap - cfg::kWriteGapTicks);
    }
    uint16_t first = at[0];
    uint8_t bit = 2;
    for (uint8_t i = 1; i < n; ++i, bit = (uint8_t)(bit << 1)) {
      const uint16_t gap = (uint16_t)(at[i] - at[i - 1]);
      if (gap < cfg::kCliLeadTicks && (uint16_t)(at[i] - first) <= cfg::kMaxOffTicks) {
        joins |= bit;
      } else if (gap < cfg::kBreatherTicks) {
        joins |= bit;
        breathe |= bit;
        first = at[i - 1];
      } else {
        first = at[i];
      }
    }
  }
  uint16_t raised[board::active::kMotorCount];
  uint8_t low = 0;
  Motor *const *op = g_order;
  const uint16_t *tp = at;
  uint16_t *rp = raised;
  for (uint8_t i = 0, bit = 1; i < n;) {
    const Motor *m = *op;
    uint16_t t = *tp;
    volatile uint8_t *port = m->step_port;
    uint8_t mask = m->step_mask;
    while ((int16_t)(t - TCNT1) > (int16_t)cfg::kCliLeadTicks) {
      if (low < i && (uint16_t)(TCNT1 - raised[low]) >= g_order[low]->pulse_ticks) {
        *g_order[low]->step_port &= (uint8_t)~g_order[low]->step_mask;  // ports: main loop and
        ++low;                                                            // nested ISRs keep off
      }
    }
    cli();
    for (;;) {
      raise_at(t, port, mask, rp);
      ++op;
      ++tp;
      ++i;
      bit = (uint8_t)(bit << 1);
      if (!(joins & bit)) break;  // also past the last raise: no bit set there
      m = *op;
      t = *tp;
      port = m->step_port;
      mask = m->step_mask;
      if (breathe & bit) {
        sei();
        __asm__ __volatile__("nop");
        cli();
      }
    }
    sei();
  }
  for (; low < n; ++low) {
    const Motor *p = g_order[low];
    while ((uint16_t)(TCNT1 - raised[low]) < p->pulse_ticks) {
    }
    *p->step_port &= (uint8_t)~p->step_mask;
  }
  for (uint8_t i = 0; i < n; ++i) {
    Motor *p = g_order[i];
    if ((int16_t)(raised[i] - (uint16_t)p->deadline) > (int16_t)kLateTicks)
      g_late_edges = (uint16_t)(g_late_edges + 1);
    p->next_rough = p->deadline + (p->period_q8 >> 8);
    g_played[g_played_count++] = p;
  }
  for (uint8_t i = n; i < active; ++i) g_order[i - n] = g_order[i];
  g_active = (uint8_t)(active - n);
}

// Called from: step ISR (interrupts on). Position, endstop bounce-back and soft limits after
// one step of m; a reversal turns DIR before the motor's next step.
inline void account_step(Motor &m) {
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
        g_motor_fault = sc::kErrEndstopStuck;
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
    *m.dir_port ^= m.dir_mask;  // main loop suspended, nested ISRs leave the ports alone
    g_reversals = (uint16_t)(g_reversals + 1);
  }
}

// Called from: step ISR (interrupts on). Next deadline of m after the step at m.deadline: one
// period on (fraction carried), the onset ramp shortening the period step by step; a pending
// restrike lands exactly on its time instead, with the new period from there.
inline void next_deadline(Motor &m) {
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
  // An old edge within kStrikeSnapTicks before the strike gives way to it. A timed silence
  // (target 0) stops the motor before its first edge at or after the time (bookkeep_one then
  // leaves it out of the order).
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

// Called from: step ISR (interrupts on), after a burst. Bookkeeping of the played motor whose
// next step comes first: position, endstops and soft limits of the step it took (a reversal
// turns DIR before its next step), then its next deadline and its place in the order.
__attribute__((always_inline)) inline void bookkeep_one() {
  uint8_t best = 0;
  uint32_t best_next = g_played[0]->next_rough;
  for (uint8_t i = 1; i < g_played_count; ++i) {
    const uint32_t next = g_played[i]->next_rough;
    if ((int32_t)(next - best_next) < 0) {
      best = i;
      best_next = next;
    }
  }
  Motor *m = g_played[best];
  g_played[best] = g_played[--g_played_count];
  account_step(*m);
  next_deadline(*m);
  if (m->period_q8 != 0) order_insert(m);  // 0: a timed silence fell before its next edge
}

// Called from: step ISR (interrupts on) and main loop (start_now). Which way a silent motor
// starts: the direction with more room ahead (the music2gcode border rule), never into a
// pressed switch.
inline bool start_up(const Motor &m) {
  bool up = m.flags & kUp;
  if (m.flags & kLimits) up = m.position < (int32_t)(m.travel_steps / 2);
  volatile uint8_t *sw = up ? m.sw_up_pin : m.sw_down_pin;
  const uint8_t mask = up ? m.sw_up_mask : m.sw_down_mask;
  // A pressed switch ahead turns it round, unless it is one input for both ends (then it says
  // nothing about which end the carriage is at: the position decides).
  if (sw && m.sw_up_pin != m.sw_down_pin && drv::switch_pressed((*sw & mask) != 0, m.flags & kActiveHigh)) up = !up;
  return up;
}

// Called from: step ISR (interrupts on) and main loop (start_now, interrupts off). Sets DIR
// (main loop suspended or interrupts off: nobody else writes the port meanwhile); true when
// it changed.
inline bool set_dir(Motor &m, bool up) {
  if (up == (bool)(m.flags & kUp) && ((*m.dir_port & m.dir_mask) != 0) == up) return false;
  if (up) {
    m.flags |= kUp;
    *m.dir_port |= m.dir_mask;
  } else {
    m.flags &= (uint8_t)~kUp;
    *m.dir_port &= (uint8_t)~m.dir_mask;
  }
  return true;
}

// Called from: step ISR and main loop (interrupts off there). A silent motor's period from its
// first edge on: the onset ramp's start period when it is longer.
inline void start_period(Motor &m, uint32_t period_q8) {
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

// Called from: step ISR (interrupts on). Starts a silent motor (direction: start_up), first
// edge at `first`, or as soon as it can be played if that has passed.
void start(Motor &m, uint32_t period_q8, uint32_t first) {
  set_dir(m, start_up(m));
  const uint32_t soonest = now_locked() + cfg::kStartLeadTicks;  // after the work above
  m.deadline = (int32_t)(first - soonest) < 0 ? soonest : first;
  start_period(m, period_q8);
  order_insert(&m);
}

// Called from: step ISR (interrupts on). A sounding motor takes a new period, keeping its
// phase: the next edge comes one new period after the last one (or soon, if that is past).
void retune(Motor &m, uint32_t period_q8) {
  uint32_t soonest;
  m.flags &= (uint8_t)~(kRamp | kRestrike);
  if (m.period_q8 == period_q8) return;
  uint16_t frac = (uint16_t)m.deadline_frac - (uint8_t)m.period_q8;
  const uint32_t last = m.deadline - (m.period_q8 >> 8) - ((frac >> 8) ? 1 : 0);
  frac = (uint16_t)(uint8_t)frac + (uint8_t)period_q8;
  uint32_t next = last + (period_q8 >> 8) + (frac >> 8);
  soonest = now_locked() + cfg::kStartLeadTicks;  // after the work above
  if ((int32_t)(next - soonest) < 0) {
    next = soonest;
    frac = 0;
  }
  order_remove(&m);
  m.deadline = next;
  m.deadline_frac = (uint8_t)frac;
  m.period_q8 = period_q8;
  order_insert(&m);
}

// Called from: step ISR (interrupts on). Motor m takes period (sc::kPeriodSilent: silence)
// now, or, timed, exactly at board time `at`. Returns false when a timed change came too late
// for its time (it is made at once).
__attribute__((noinline)) bool apply(Motor &m, uint32_t period, bool want_timed, uint32_t at) {
  uint32_t now;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = now_locked(); }
  const uint32_t soonest = now + cfg::kStartLeadTicks;
  const bool timed = want_timed && (int32_t)(at - soonest) > 0;
  if (m.period_q8 == 0 && period == sc::kPeriodSilent) {
    m.flags &= (uint8_t)~(kRamp | kRestrike);  // silent already (a timed silence may be pending)
  } else if (period == sc::kPeriodSilent && (!timed || (int32_t)(m.deadline - at) >= 0)) {
    // Now, or at a time before the motor's next edge (which would be the first one silenced).
    order_remove(&m);
    m.period_q8 = 0;
    m.flags &= (uint8_t)~(kRamp | kRestrike);
  } else if (m.period_q8 == 0) {
    start(m, period, timed ? at : soonest);
  } else if (!timed) {
    retune(m, period);
  } else if ((int32_t)(m.deadline - at) >= -kStrikeSnapTicks) {
    // The next edge not before the time, or just before it: strike on it.
    order_remove(&m);
    m.deadline = at;
    m.deadline_frac = 0;
    m.period_q8 = period;
    m.flags &= (uint8_t)~(kRamp | kRestrike);
    order_insert(&m);
  } else {  // strike (or fall silent) on the time, after the edges still due before it
    m.target_q8 = period;
    m.restrike_at = at;
    m.flags = (uint8_t)((m.flags & ~kRamp) | kRestrike);
  }
  return timed || !want_timed;
}

// Called from: step ISR (interrupts on). Carries out one command from a motor's mailbox.
__attribute__((noinline)) void apply_one() {
  uint8_t mi = 0;
  while (!(g_cmd_mask & (1u << mi))) ++mi;
  Motor &m = g_motor[mi];
  uint32_t period;
  cli();
  period = m.cmd_period_q8;
  g_cmd_mask &= (uint8_t)~(1u << mi);
  sei();
  apply(m, period, false, 0);
}

// Called from: step ISR. The oldest timestamped entry, when it is due within kTakeTicks and
// its motor holds no timed change still to come (a second would replace it; the entry waits
// until that one has become the motor's next edge). Null otherwise.
inline const AtSlot *entry_due(uint32_t now) {
  if (g_q_put == g_q_taken) return 0;
  const AtSlot &e = g_q[g_q_take_idx];
  const int32_t ahead = (int32_t)(e.at - now);
  if (ahead > (int32_t)cfg::kTakeTicks) return 0;
  if ((g_motor[e.motor].flags & kRestrike) && ahead > (int32_t)cfg::kStartLeadTicks) return 0;
  if (g_claimed & (1u << e.motor)) return 0;  // after start_now's hand-over (a strike, then)
  return &e;
}

// Called from: step ISR (interrupts on). Takes the oldest timestamped entry (entry_due).
__attribute__((noinline)) void take_one(const AtSlot *e) {
  const AtSlot slot = *e;
  g_q_take_idx = (uint8_t)(g_q_take_idx + 1 == cfg::kQueueSize ? 0 : g_q_take_idx + 1);
  g_q_taken = (uint8_t)(g_q_taken + 1);
  if (!apply(g_motor[slot.motor], slot.period_q8, true, slot.at)) {
    g_late_motor = slot.motor;
    g_late_entries = (uint8_t)(g_late_entries + 1);
  }
}

// Called from: step ISR, interrupts off. Arms OCR1A kEarlyTicks before the next deadline, or
// for a timer wake. Returns false when the next deadline is due too soon to arm for: the ISR
// plays it now.
__attribute__((noinline)) bool arm() {
  const uint32_t now = now_locked();
  uint32_t target = now + cfg::kWakeTicks;
  if (g_active) {
    const uint32_t head = g_order[0]->deadline;
    if ((int32_t)(head - now) <= (int32_t)(cfg::kEarlyTicks + cfg::kMinLeadTicks)) return false;
    if ((int32_t)(head - cfg::kEarlyTicks - now) <= (int32_t)cfg::kWakeTicks) target = head - cfg::kEarlyTicks;
  }
  g_armed = target;
  OCR1A = (uint16_t)target;
  TIFR1 = _BV(OCF1A);
  return true;
}

// Called from: main loop, interrupts off. Makes sure the step ISR comes within kPostLeadTicks.
void wake_soon() {
  const uint32_t soon = now_locked() + cfg::kPostLeadTicks;
  if ((int32_t)(g_armed - soon) > 0) {
    g_armed = soon;
    OCR1A = (uint16_t)soon;
    TIFR1 = _BV(OCF1A);
  }
}

// Called from: main loop. Leaves a period in motor mi's mailbox (to play from now on) and
// makes sure the step ISR comes for it within kPostLeadTicks. Interrupts off for about 60
// cycles.
void post(uint8_t mi, uint32_t period_q8) {
  Motor &m = g_motor[mi];
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    m.cmd_period_q8 = period_q8;
    g_cmd_mask |= (uint8_t)(1u << mi);
    wake_soon();
  }
}

// An edge of another motor due sooner than this (ticks) keeps the main loop from starting a
// motor itself (start_now): its critical sections (the check and the raise) would hold up the
// step ISR, whose compare fires kEarlyTicks before that edge.
const uint16_t kDirectClearTicks = cfg::kEarlyTicks + 600;

// Called from: main loop, interrupts off. True when no edge is due within kDirectClearTicks:
// neither the order's head nor a motor waiting for the step ISR's bookkeeping.
bool clear_ahead(uint32_t now) {
  if (g_active && (int32_t)(g_order[0]->deadline - now) < (int32_t)kDirectClearTicks) return false;
  for (uint8_t i = 0; i < g_played_count; ++i)
    if ((int32_t)(g_played[i]->next_rough - now) < (int32_t)kDirectClearTicks) return false;
  return true;
}

// Called from: main loop (hal::set_period). Starts silent motor mi at once: the main loop sets
// DIR (start_up), raises the first edge itself and leaves the motor to the step ISR as played,
// whose bookkeeping schedules the next edge one period on. A note's onset then does not wait
// for the step ISR to come for a posted command (kPostLeadTicks), its loop and
// kStartLeadTicks: about 1,000 cycles (`test_e2e "link: a note starts*"`). Returns false when
// the motor sounds or an edge is due within kDirectClearTicks: the caller posts the command
// instead. When DIR turns, the first edge follows a pulse width later (2-10 us: every
// supported driver's DIR set-up time, the TB6600's 5 us included).
// The motor is claimed (g_claimed) from the first check to the hand-over: the step ISR leaves
// it alone (it is in neither list, its mailbox is emptied, its queue entries wait), so only the
// check and DIR, the raise, the lowering and the hand-over's list entry need interrupts off;
// the DIR wait, the pulse and the 32-bit stores run with them on (all in one critical
// section, interrupts stayed off 341 cycles on the Uno, 428 on the Mega: over the ~15 us the
// UART's two bytes allow). Measured: `irq_off_max_cycles` in build/e2e/link-onset-<board>.csv.
static_assert(cfg::kPulseUsMax * (F_CPU / 1000000ul) < 256u, "start_now: DIR set-up is timed on TCNT1L");
bool start_now(uint8_t mi, uint32_t period_q8) {
  Motor &m = g_motor[mi];
  const uint8_t bit = (uint8_t)(1u << mi);
  const bool up = start_up(m);  // a torn read only if the motor sounds: checked below
  bool turned;
  uint16_t raised = 0;
  uint32_t now = 0;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    now = now_locked();
    if (m.period_q8 != 0 || !clear_ahead(now)) return false;
    g_claimed |= bit;
    g_cmd_mask &= (uint8_t)~bit;  // an older command for it is superseded
    turned = set_dir(m, up);
    if (!turned) {
      *m.step_port |= m.step_mask;
      raised = TCNT1;
    }
  }
  if (turned) {
    // The low byte alone: a 16-bit read with interrupts on could take a nested ISR's high
    // byte (the timer's shared TEMP register); pulse_ticks <= 160.
    const uint8_t t = TCNT1L;
    while ((uint8_t)(TCNT1L - t) < (uint8_t)m.pulse_ticks) {
    }
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      now = now_locked();
      *m.step_port |= m.step_mask;
      raised = TCNT1;
    }
  }
  // The pulse, with interrupts on (a nested ISR only makes it longer; the motor's next edge
  // is scheduled only after the hand-over below).
  const uint8_t r = (uint8_t)raised;
  while ((uint8_t)(TCNT1L - r) < (uint8_t)m.pulse_ticks) {
  }
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { *m.step_port &= (uint8_t)~m.step_mask; }
  m.deadline = now + (uint16_t)(raised - (uint16_t)now);
  start_period(m, period_q8);
  m.next_rough = m.deadline + (m.period_q8 >> 8);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_played[g_played_count++] = &m;  // silent and claimed, it was in neither list
    g_claimed &= (uint8_t)~bit;
    wake_soon();
  }
  return true;
}

}  // namespace

void init(uint8_t motor_count, const Wiring *wiring) {
  g_count = motor_count;
  for (uint8_t i = 0; i < motor_count; ++i) {
    Motor &m = g_motor[i];
    const Wiring &w = wiring[i];
    pio::output(w.step, false);
    pio::output(w.dir, true);
    pio::input(w.min_switch, true);
    pio::input(w.max_switch, true);
    m.step_port = pio::port_reg(w.step.port);
    m.step_mask = pio::mask(w.step);
    m.dir_port = pio::port_reg(w.dir.port);
    m.dir_mask = pio::mask(w.dir);
    m.sw_up_pin = w.max_switch.wired() ? pio::pin_reg(w.max_switch.port) : 0;
    m.sw_up_mask = pio::mask(w.max_switch);
    m.sw_down_pin = w.min_switch.wired() ? pio::pin_reg(w.min_switch.port) : 0;
    m.sw_down_mask = pio::mask(w.min_switch);
    m.flags = kUp | kArmed;
    m.period_q8 = 0;
    m.pulse_ticks = (uint16_t)(cfg::kPulseUsA4988 * (F_CPU / 1000000ul));
    Motion motion = {cfg::kDefaultTravelSteps, m.pulse_ticks, false, 0, 0};
    set_motion(i, motion);
  }
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_active = 0;
    g_played_count = 0;
    g_cmd_mask = 0;
    TCCR1A = 0;               // normal mode: simavr times it exactly (phase-correct PWM it does not)
    TCCR1B = _BV(CS10);       // no prescaler
    TCCR1C = 0;
    TCNT1 = 0;
    g_armed = 0;
    arm();
    TIMSK1 = _BV(OCIE1A);
  }
}

void set_motion(uint8_t mi, const Motion &motion) {
  Motor &m = g_motor[mi];
  // Work out the new limits first: interrupts stay off only for the stores.
  const bool limits = motion.travel_steps != 0;
  const int32_t hi = (int32_t)motion.travel_steps + (m.sw_up_pin ? cfg::kSoftMarginSteps : 0);
  const int32_t lo = -(int32_t)(m.sw_down_pin ? cfg::kSoftMarginSteps : 0);
  // A new travel puts the carriage at its middle (where it should be at power-up); the same
  // travel again keeps the position the motor has counted.
  const bool recentre = limits && (!(m.flags & kLimits) || m.travel_steps != motion.travel_steps);
  const int32_t centre = (int32_t)(motion.travel_steps / 2);
  uint8_t set = limits ? kLimits : 0, clear = limits ? 0 : kLimits;
  if (motion.switch_active_high) set |= kActiveHigh;
  else clear |= kActiveHigh;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    m.pulse_ticks = motion.pulse_ticks;
    m.start_q8 = motion.start_period_q8;
    m.ramp_q8 = motion.ramp_q8;
    m.flags = (uint8_t)((m.flags & ~clear) | set);
    if (recentre) m.position = centre;
    m.limit_hi = hi;
    m.limit_lo = lo;
    m.travel_steps = motion.travel_steps;
  }
}

void main_loop_alive() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_main_pass = now_locked();
    g_isr_busy = 0;
  }
}

void rescue_missed_compare() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    const int16_t past = (int16_t)(TCNT1 - (uint16_t)g_armed);
    if (past > (int16_t)cfg::kRescueTicks) {  // the compare should have fired long ago
      g_armed = now_locked() + cfg::kMinLeadTicks;
      OCR1A = (uint16_t)g_armed;
      TIFR1 = _BV(OCF1A);
      g_late_edges = (uint16_t)(g_late_edges + 1);  // what it was armed for comes late
    }
  }
}

void silence_all() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_active = 0;
    g_played_count = 0;  // between ISR invocations: only motors start_now just started
    g_cmd_mask = 0;
    for (uint8_t i = 0; i < g_count; ++i) {
      g_motor[i].period_q8 = 0;
      g_motor[i].flags &= (uint8_t)~(kRamp | kRestrike);
    }
    g_q_taken = g_q_put;  // the queue's entries with them
    g_q_take_idx = g_q_put_idx;
  }
}


}  // namespace sched

// Step ISR. Who: Timer1 compare A, kEarlyTicks before each deadline, every 2 ms to extend the
// timer, or kPostLeadTicks after the main loop posted a command. It masks itself and runs with
// interrupts on (the UART nests freely) except from kCliLeadTicks before each edge until it
// is raised. Work comes in small pieces (one motor's rescheduling and step bookkeeping, one
// command), each started only when no edge is due within kBookkeepTicks / kSoonTicks: a played
// motor first, as its own next edge may follow soon. It returns when nothing is left to do and
// the next edge is far enough to come back for it.
// Measured on the virtual board (tools/bench/run-bench.sh, bench/results/pitch-<board>.md):
// interrupts off at most 237 cycles (uno) / 243 (mega), from the last cli below before it
// returns (236 / 242 at its entry before it held the transmitter off), also
// with frames back to back at full line speed (a burst's runs stay under that: kCliLeadTicks +
// kMaxOffTicks + a raise); one invocation up to 18,673 cycles (uno) / 15,189 (mega) with
// interrupts on, while four or five motors play (25,500 at full line speed); CPU load 40 % (uno) / 50 % (mega) with every
// motor sounding, much of it waiting for edges with interrupts on (kEarlyTicks).
ISR(TIMER1_COMPA_vect) {
  using namespace sched;
  // Idle (no motor sounds, nothing posted or queued): only the 16-bit timer's extension, every
  // kWakeTicks. Kept short (the loop below took about 400 cycles for it): a note's frame that
  // came meanwhile waited that long (`test_e2e "link: a note starts*"`: p99 with 500 notes).
  if (!g_active && !g_played_count && !g_cmd_mask && g_q_put == g_q_taken) {
    const uint32_t now = now_locked();
    g_armed = now + cfg::kWakeTicks;
    OCR1A = (uint16_t)g_armed;
    g_isr_busy += kIsrEntryExitTicks;
    return;
  }
  TIMSK1 &= (uint8_t)~_BV(OCIE1A);  // no re-entry, however long the loop below runs
  sei();
  uint8_t tx = link::hold_tx();  // a reply waits for the return (link.h)
  const uint16_t entered = TCNT1;
  const uint8_t rx_entered = link::rx_head();
  for (;;) {
    const uint32_t now = now_locked();  // nested ISRs touch neither TCNT1 nor g_armed
    g_armed = now;  // keep the 16-bit extension fresh however long the loop runs
    // Overload: kMaxInvocationTicks into this invocation, or when the main loop has not begun a
    // pass for 8 * kMaxIsrTicks and this ISR took 3/4 of that time, the ISR stops waiting for
    // edges (it plays only those already due) and returns as soon as its work is done,
    // leaving the main loop kMainSliceTicks. Edges are then late, but frames, stop-all and the
    // watchdog keep working. (With every motor near the top of its range the ISR returns
    // often, but into gaps that leave the main loop a few cycles each: counted per invocation
    // only, a pass of the main loop took up to 16 ms and clock replies stopped for seconds. A
    // main loop busy with frames at full line speed must not get slices: after 2-4 ms they
    // made edges late in `test_e2e "*frames at full speed"` one run in five; the receive ISR's
    // bytes nested in this one do not count as its time.)
    const uint16_t in_isr = (uint16_t)(TCNT1 - entered);
    const uint32_t since_main = now - g_main_pass;
    const bool overdue = in_isr > cfg::kMaxInvocationTicks ||
                         (since_main > 8ul * cfg::kMaxIsrTicks && g_isr_busy + own_ticks(in_isr, rx_entered) > since_main - (since_main >> 2));
    const AtSlot *entry = entry_due(now);
    // An entry close to its time goes before any edge not yet due (with every motor high,
    // edges are close all the time and it would wait until too late), once the played motors'
    // bookkeeping is done (a played motor is in neither list: apply() would put it in the order
    // twice); meanwhile only edges already due are played.
    const bool urgent = entry && (int32_t)(entry->at - now) < (int32_t)cfg::kTakeUrgentTicks;
    if (urgent && !g_played_count) {
      take_one(entry);
      continue;
    }
    if (g_active) {
      // Wait for the edge when the next piece of work might not fit before it, or, with no
      // work left, when it is too close to return and come back for it. A played motor's
      // bookkeeping comes first whenever it fits: its own next edge may follow soon. A live
      // command waits for close edges only kCmdWaitTicks into the invocation (with every motor
      // high an edge is always close); a due entry has until it is urgent (above).
      // While UART bytes come in, the receive ISR (up to 30 % of the CPU) stretches the
      // bookkeeping and the burst's plan: it starts only further from the head (the UART state
      // is read only when a played motor waits; a full ring counts as bytes coming in, see
      // rx_full; the transmit ISR is held off, see hold_tx).
      const int32_t ahead = (int32_t)(g_order[0]->deadline - now);
      const uint16_t wait_within = overdue || urgent ? 0
                                   : g_played_count    ? (link::rx_head() != rx_entered || link::rx_full()
                                                              ? cfg::kBookkeepBusyTicks
                                                              : cfg::kBookkeepTicks)
                                   : g_cmd_mask        ? (in_isr > cfg::kCmdWaitTicks ? 0 : cfg::kSoonTicks)
                                   : entry             ? cfg::kSoonTicks
                                                       : cfg::kEarlyTicks + cfg::kMinLeadTicks;
      if (ahead <= (int32_t)wait_within) {
        burst();
        continue;
      }
    }
    if (g_played_count) {
      bookkeep_one();
    } else if (g_cmd_mask) {
      apply_one();
    } else if (entry) {
      take_one(entry);
    } else {
      const uint16_t own = own_ticks((uint16_t)(TCNT1 - entered), rx_entered);  // before cli: it takes a while
      link::release_tx(tx);  // before the cli: after it, it lengthened the ISR's longest interrupts-off stretch
      cli();
      if (overdue) {
        g_armed = now_locked() + cfg::kMainSliceTicks;
        OCR1A = (uint16_t)g_armed;
        TIFR1 = _BV(OCF1A);
      } else if (!arm()) {
        sei();
        tx = link::hold_tx();
        continue;
      }
      TIMSK1 |= _BV(OCIE1A);
      g_isr_busy += own + kIsrEntryExitTicks;
      return;  // reti sets I again
    }
  }
}

namespace hal {

uint32_t now_ticks() {
  uint32_t t;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = sched::now_locked(); }
  return t;
}

void set_period(uint8_t m, uint32_t period_q8) {
  // A silent motor whose driver is awake starts at once (sched::start_now); a driver just
  // woken gets the step ISR's start lead (kStartLeadTicks, 18.75 us: a TB6600 wants ENA 5 us
  // before DIR).
  if (period_q8 != sc::kPeriodSilent && !drivers::enable_for(m) && sched::start_now(m, period_q8)) return;
  sched::post(m, period_q8);
}

uint8_t queue_used() { return (uint8_t)(sched::g_q_put - sched::g_q_taken); }

void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) {
  if (period_q8 != sc::kPeriodSilent) drivers::enable_for(m);
  sched::AtSlot &slot = sched::g_q[sched::g_q_put_idx];
  slot.at = at_ticks;
  slot.period_q8 = period_q8;
  slot.motor = m;
  sched::g_q_put_idx = (uint8_t)(sched::g_q_put_idx + 1 == cfg::kQueueSize ? 0 : sched::g_q_put_idx + 1);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    sched::g_q_put = (uint8_t)(sched::g_q_put + 1);  // the slot is the ISR's from here on
    sched::wake_soon();  // an entry due before the ISR's next wake is taken in time
  }
}

uint8_t late_entries(uint8_t *motor) {
  uint8_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    n = sched::g_late_entries;
    *motor = sched::g_late_motor;
  }
  return n;
}

void motor_status(uint8_t m, sc::StatusMotor *out) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    const sched::Motor &mo = sched::g_motor[m];
    out->position_steps = mo.position;
    out->flags = (uint8_t)(((mo.flags & sched::kUp) ? sc::kMotorDirUp : 0) |
                           (mo.period_q8 ? sc::kMotorSounding : 0) |
                           ((mo.flags & sched::kFault) ? sc::kMotorEndstopFault : 0));
  }
}

uint16_t reversals() {
  uint16_t r;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { r = sched::g_reversals; }
  return r;
}

uint16_t late_edges() {
  uint16_t r;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { r = sched::g_late_edges; }
  return r;
}

uint8_t last_motor_fault() { return sched::g_motor_fault; }

void reset_step_counters() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    sched::g_reversals = 0;
    sched::g_late_edges = 0;
    sched::g_motor_fault = 0;
  }
}

}  // namespace hal

// scheduler.cpp: the step ISR and the motor table it works on (AVR only).
#include "scheduler.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "config.h"
#include "hal.h"
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

struct Motor {
  uint32_t deadline;          // ticks of the next STEP rising edge
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
  uint32_t target_q8;         // ramp target period
  uint32_t ramp_q8;           // ramp: period shrink per step
  uint32_t start_q8;          // ramp: first period (0 = no ramp)
  uint32_t released_since;    // ticks: the switch has read released since then
  uint16_t pressed_steps;     // steps taken while the switch still reads pressed
};

Motor g_motor[5];
uint8_t g_count;
uint8_t g_order[5];            // sounding motors, earliest deadline first
volatile uint8_t g_active;     // how many of g_order are valid
uint32_t g_armed;              // 32-bit time OCR1A is armed for (always within 32768 ticks)
bool g_arm_is_edge;            // the armed time is g_order[0]'s deadline (else a timer wake)
volatile uint16_t g_reversals;
volatile uint16_t g_late_edges;
volatile uint8_t g_motor_fault;

const uint16_t kLateTicks = 128;  // an edge raised more than 8 us after its deadline is late

// Called from: step ISR, main loop (interrupts off). Inserts motor mi by deadline.
void order_insert(uint8_t mi) {
  const uint32_t d = g_motor[mi].deadline;
  uint8_t pos = g_active;
  while (pos > 0 && (int32_t)(g_motor[g_order[pos - 1]].deadline - d) > 0) {
    g_order[pos] = g_order[pos - 1];
    --pos;
  }
  g_order[pos] = mi;
  g_active = (uint8_t)(g_active + 1);
}

// Called from: main loop (interrupts off). Removes motor mi if it is sounding.
void order_remove(uint8_t mi) {
  uint8_t n = g_active, i = 0;
  while (i < n && g_order[i] != mi) ++i;
  if (i == n) return;
  for (; i + 1 < n; ++i) g_order[i] = g_order[i + 1];
  g_active = (uint8_t)(n - 1);
}

// Called from: step ISR (interrupts off). Raises every motor due within kChainTicks of the
// armed time, each at its own tick, holds the longest pulse, lowers them. Returns how many.
// Cycles: about 30 per motor raised + the pulse; interrupts stay off throughout.
inline uint8_t burst() {
  const uint32_t start = g_armed;
  const uint8_t active = g_active;
  uint8_t n = 0;
  uint16_t pulse = 0;
  while (n < active) {
    Motor &m = g_motor[g_order[n]];
    if ((int32_t)(m.deadline - start) > (int32_t)cfg::kChainTicks) break;
    const uint16_t t = (uint16_t)m.deadline;
    while ((int16_t)(t - TCNT1) > 0) {
    }
    *m.step_port |= m.step_mask;
    if ((uint16_t)(TCNT1 - t) > kLateTicks) g_late_edges = (uint16_t)(g_late_edges + 1);
    if (m.pulse_ticks > pulse) pulse = m.pulse_ticks;
    ++n;
  }
  const uint16_t last = TCNT1;
  while ((uint16_t)(TCNT1 - last) < pulse) {
  }
  for (uint8_t i = 0; i < n; ++i) {
    Motor &m = g_motor[g_order[i]];
    *m.step_port &= (uint8_t)~m.step_mask;
  }
  return n;
}

// Called from: step ISR bookkeeping (interrupts on, OCIE1A off). Accounts one step of m:
// position, endstop bounce-back, soft limits, onset ramp, next deadline.
inline void advance(Motor &m) {
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
        if (m.flags & kLimits) m.position = up ? (int32_t)m.travel_steps : 0;
      } else if (++m.pressed_steps > cfg::kStuckSteps) {
        m.flags |= kFault;
        m.sw_up_pin = 0;
        m.sw_down_pin = 0;
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
    *m.dir_port ^= m.dir_mask;
    g_reversals = (uint16_t)(g_reversals + 1);
  }
  if (m.flags & kRamp) {
    if (m.period_q8 > m.target_q8 + m.ramp_q8) {
      m.period_q8 -= m.ramp_q8;
    } else {
      m.period_q8 = m.target_q8;
      m.flags &= (uint8_t)~kRamp;
    }
  }
  const uint16_t frac = (uint16_t)m.deadline_frac + (uint8_t)m.period_q8;
  m.deadline_frac = (uint8_t)frac;
  m.deadline += (m.period_q8 >> 8) + (frac >> 8);
}

// Called from: step ISR and main loop, interrupts off. Arms OCR1A for the next deadline or a
// timer wake. Returns false when the head is due too soon to arm: the caller plays it now.
inline bool arm() {
  if (g_active) {
    const uint32_t head = g_motor[g_order[0]].deadline;
    if ((int32_t)(head - g_armed) <= (int32_t)cfg::kWakeTicks) {
      g_armed = head;
      g_arm_is_edge = true;
      OCR1A = (uint16_t)head;
      if ((int16_t)((uint16_t)head - TCNT1) < (int16_t)cfg::kMinLeadTicks) return false;
      TIFR1 = _BV(OCF1A);
      return true;
    }
  }
  g_armed += cfg::kWakeTicks;
  g_arm_is_edge = false;
  OCR1A = (uint16_t)g_armed;
  TIFR1 = _BV(OCF1A);
  return true;
}

// Called from: main loop, interrupts off. Current board time in ticks.
inline uint32_t now_locked() { return g_armed + (int16_t)(TCNT1 - (uint16_t)g_armed); }

// Called from: main loop, interrupts off. Re-arms when motor mi became the earliest deadline.
inline void rearm_for(uint8_t mi) {
  if (g_order[0] != mi) return;
  if (g_arm_is_edge && (int32_t)(g_motor[mi].deadline - g_armed) >= 0) return;
  g_armed = g_motor[mi].deadline;
  g_arm_is_edge = true;
  OCR1A = (uint16_t)g_armed;
  TIFR1 = _BV(OCF1A);
}

// Called from: main loop. Starts a silent motor: direction with more room ahead (the
// music2gcode border rule, never into a pressed switch), first edge at `first` ticks.
void start(uint8_t mi, uint32_t period_q8, uint32_t first) {
  Motor &m = g_motor[mi];
  bool up = m.flags & kUp;
  if (m.flags & kLimits) up = m.position < (int32_t)(m.travel_steps / 2);
  volatile uint8_t *sw = up ? m.sw_up_pin : m.sw_down_pin;
  const uint8_t mask = up ? m.sw_up_mask : m.sw_down_mask;
  if (sw && drv::switch_pressed((*sw & mask) != 0, m.flags & kActiveHigh)) up = !up;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (up) { m.flags |= kUp; *m.dir_port |= m.dir_mask; }
    else { m.flags &= (uint8_t)~kUp; *m.dir_port &= (uint8_t)~m.dir_mask; }
    const uint32_t now = now_locked();
    if ((int32_t)(first - now) < (int32_t)cfg::kStartLeadTicks) first = now + cfg::kStartLeadTicks;
    m.deadline = first;
    m.deadline_frac = 0;
    if (m.start_q8 > period_q8) {
      m.period_q8 = m.start_q8;
      m.target_q8 = period_q8;
      m.flags |= kRamp;
    } else {
      m.period_q8 = period_q8;
      m.flags &= (uint8_t)~kRamp;
    }
    order_insert(mi);
    rearm_for(mi);
  }
}

// Called from: main loop. Changes a sounding motor's period, keeping its phase: the next
// edge comes one new period after the last one (or at once if that is already past).
void retune(uint8_t mi, uint32_t period_q8) {
  Motor &m = g_motor[mi];
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (m.period_q8 == period_q8 && !(m.flags & kRamp)) return;
    // last edge = deadline - old period; next = last + new period (both with fractions)
    uint16_t frac = (uint16_t)m.deadline_frac - (uint8_t)m.period_q8;
    uint32_t last = m.deadline - (m.period_q8 >> 8) - ((frac >> 8) ? 1 : 0);
    frac = (uint16_t)(uint8_t)frac + (uint8_t)period_q8;
    uint32_t next = last + (period_q8 >> 8) + (frac >> 8);
    const uint32_t now = now_locked();
    if ((int32_t)(next - now) < (int32_t)cfg::kStartLeadTicks) {
      next = now + cfg::kStartLeadTicks;
      frac = 0;
    }
    m.deadline = next;
    m.deadline_frac = (uint8_t)frac;
    m.period_q8 = period_q8;
    m.flags &= (uint8_t)~kRamp;
    order_remove(mi);
    order_insert(mi);
    rearm_for(mi);
  }
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
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    m.travel_steps = motion.travel_steps;
    m.pulse_ticks = motion.pulse_ticks;
    m.start_q8 = motion.start_period_q8;
    m.ramp_q8 = motion.ramp_q8;
    if (motion.switch_active_high) m.flags |= kActiveHigh;
    else m.flags &= (uint8_t)~kActiveHigh;
    if (motion.travel_steps) {
      m.flags |= kLimits;
      m.position = (int32_t)(motion.travel_steps / 2);
      const int32_t margin_hi = m.sw_up_pin ? cfg::kSoftMarginSteps : 0;
      const int32_t margin_lo = m.sw_down_pin ? cfg::kSoftMarginSteps : 0;
      m.limit_hi = (int32_t)motion.travel_steps + margin_hi;
      m.limit_lo = -margin_lo;
    } else {
      m.flags &= (uint8_t)~kLimits;
    }
  }
}

void silence_all() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_active = 0;
    for (uint8_t i = 0; i < g_count; ++i) g_motor[i].period_q8 = 0;
  }
}

bool sounding(uint8_t mi) {
  bool s;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { s = g_motor[mi].period_q8 != 0; }
  return s;
}

}  // namespace sched

// Step ISR. Who: Timer1 compare A, at each armed deadline or timer wake (every <= 2 ms).
// Budget: interrupts off for the burst (30 cycles a motor + the chain wait <= kChainTicks +
// the pulse), then bookkeeping with interrupts on (about 120 cycles a motor). Measured worst
// cycles are in bench/results (tools/bench/isr_bench.sh).
ISR(TIMER1_COMPA_vect) {
  using namespace sched;
  for (;;) {
    if (g_arm_is_edge && (int16_t)(TCNT1 - (uint16_t)g_armed) >= -(int16_t)cfg::kMinLeadTicks) {
      const uint8_t n = burst();
      TIMSK1 &= (uint8_t)~_BV(OCIE1A);
      sei();
      uint8_t moved[5];
      for (uint8_t i = 0; i < n; ++i) {
        moved[i] = g_order[i];
        advance(g_motor[moved[i]]);
      }
      const uint8_t active = g_active;
      for (uint8_t i = n; i < active; ++i) g_order[i - n] = g_order[i];
      g_active = (uint8_t)(active - n);
      for (uint8_t i = 0; i < n; ++i) order_insert(moved[i]);
      cli();
      TIMSK1 |= _BV(OCIE1A);
    }
    if (arm()) return;
  }
}

namespace hal {

uint32_t now_ticks() {
  uint32_t t;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = sched::now_locked(); }
  return t;
}

void set_period(uint8_t m, uint32_t period_q8) {
  if (period_q8 == sc::kPeriodSilent) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      sched::order_remove(m);
      sched::g_motor[m].period_q8 = 0;
    }
  } else if (sched::sounding(m)) {
    sched::retune(m, period_q8);
  } else {
    drivers::enable_for(m);
    sched::start(m, period_q8, 0);
  }
}

void set_period_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) {
  if (period_q8 != sc::kPeriodSilent && !sched::sounding(m)) {
    drivers::enable_for(m);
    sched::start(m, period_q8, at_ticks);
  } else {
    set_period(m, period_q8);
  }
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

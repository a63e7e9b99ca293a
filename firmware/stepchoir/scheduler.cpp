// scheduler.cpp: the step path's one translation unit (AVR only): the motor table, board time,
// each motor's ISR (stub and handler), the main loop's commands to the motors, the timed
// queue's polling, status, and init. The main loop calls it through scheduler.h (stepchoir.ino,
// hal.cpp, moves.cpp, step_driver.cpp). What it builds on sits in headers that the handlers
// inline:
//   arm.h           arming a compare channel, and the match count the stub keeps meanwhile
//   motor.h         pure motor logic (host-tested)     timed_queue.h   the timed queue (pure)
//   chip/channel.h  compare channels and busy bits per chip family (channels_m328p.h,
//                   channels_m2560.h); chip/step_pin.h: STEP pins from the board table;
//                   chip/emulator.h: the virtual board's workarounds
// How an edge is made: scheduler.h. Budgets: docs/ARCHITECTURE.md.
#include "scheduler.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "arm.h"
#include "boards/board.h"
#include "chip/channel.h"
#include "chip/stub.h"
#include "config.h"
#include "link.h"
#include "motor.h"
#include "pin_io.h"
#include "timed_queue.h"

namespace sched {
namespace {

const uint8_t kMotors = board::active::kMotorCount;

Motor g_motor[kMotors];
// Bit m: motor m sounds, and its channel belongs to its ISR. Set by the main loop when it
// starts a silent motor, cleared by the ISR when the motor falls silent (or by stop-all).
volatile uint8_t g_sounding;
volatile uint32_t g_time_base;  // a recent board time (see now())
TimedQueue g_queue;             // timestamped entries (kMsgAt): the main loop's alone

// From the stub's raise to the handler's first timer read (ticks): the stub's jump, the
// handler's sei and register saves (45 cycles by the disassembly; less is safe: a pulse is then
// a little longer than asked).
const uint8_t kStubToHandlerTicks = 40;

}  // namespace

// Timer1's count extended from g_time_base, a time at most 32,767 ticks old (Timer0's ISR moves
// it on every 16,384 ticks).
__attribute__((noinline)) uint32_t now() {
  uint32_t base;
  uint16_t lo;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    base = g_time_base;
    lo = TCNT1;
  }
  return base + (int16_t)(lo - (uint16_t)base);
}

namespace {

// Motor m's handler after its stub: an edge (STEP was raised), or a visit (a command to take,
// or a count the stub could not hold). Interrupts on throughout but for short critical
// sections; the busy bit keeps the channel's own matches out while it runs. Called from:
// SC_STEP_ENTRY (edge and visit); budget: a few hundred cycles (the pitch benchmark measures
// its worst invocation, nested ISRs included).
template <uint8_t M> __attribute__((always_inline)) inline void serve(bool edge) {
  Motor &m = g_motor[M];
  uint16_t raised;  // when STEP rose (ticks): the stub raised it kStubToHandlerTicks or more before
  ATOMIC_BLOCK(ATOMIC_FORCEON) { raised = (uint16_t)(TCNT1 - kStubToHandlerTicks); }
  link::rx_resume();  // nested in the receive ISR, it lets the bytes that come meanwhile in
  uint8_t lowered = 0;
  for (;;) {
    if (edge) {
      // The pulse first (a TB6600 asks 5 us: measured from the raise, it is about that), then
      // the step's bookkeeping.
      while ((uint8_t)(TCNT1L - (uint8_t)raised) < m.pulse_ticks) {
      }
      StepPin<M>::lower();
      lowered = TCNT1L;
      account_step(m);
      next_deadline(m);
    }
    if (m.cmd != kCmdNone) take_command(M, m);
    if (m.period_q8 == 0) {
      ATOMIC_BLOCK(ATOMIC_FORCEON) {
        g_sounding &= (uint8_t)~_BV(M);
        GPIOR0 &= (uint8_t)~_BV(M);
      }
      return;  // still busy: the channel's matches return at once until it starts again
    }
    if (arm<M>(m.deadline)) break;
    // Due now or past (a visit came late, or the ISR was held up): raised here, late, STEP low
    // a pulse width at least; status counts it (late_edges: the edges not raised by their
    // channel's compare).
    if (edge) {
      while ((uint8_t)(TCNT1L - lowered) < m.pulse_ticks) {
      }
    }
    ATOMIC_BLOCK(ATOMIC_FORCEON) {
      StepPin<M>::raise();
      raised = TCNT1;
    }
    g_count.late_edges = (uint16_t)(g_count.late_edges + 1);
    edge = true;
  }
}

// Called from: main loop, after a command was left in a sounding motor's mailbox. Brings
// the channel's ISR (a visit) within kTriggerLeadTicks, or at its next match when that one
// would only be counted, unless the motor's next edge is due within kVisitMarginTicks: then
// that edge's handler takes the command (a visit that close, held up by the handlers nested in
// it, can come to arming after the edge: docs/decisions/012-visit-margin.md). A timed change due
// before that edge (or just after it: a strike would replace it) is brought at once all the
// same. Interrupts off for about 20 cycles at a time.
template <uint8_t M> void poke() {
  Motor &m = g_motor[M];
  uint32_t next;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { next = m.deadline; }
  // (Had the motor's handler run since, it took the command: the check below finds it gone.)
  const bool soon = (int32_t)(next - now()) <= (int32_t)cfg::kVisitMarginTicks;
  if (soon && !(m.cmd == kCmdTimed && (int32_t)(m.cmd_at - next) < kStrikeSnapTicks)) return;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if ((g_sounding & _BV(M)) && m.cmd != kCmdNone) {
      // (A match that came since the cli waits with its flag: ahead() reads it a wrap away, and
      // it enters its stub as soon as interrupts are on. The flag is read after ahead().)
      if (Chan<M>::ahead() > cfg::kTriggerAfterTicks && !Chan<M>::waiting()) {
        Chan<M>::trigger();
        g_wraps[M] = kWrapsVisit;
        GPIOR0 |= _BV(M);
      } else if (GPIOR0 & _BV(M)) {
        g_wraps[M] = kWrapsVisit;  // the next match, one the stub would count, enters the handler
      }  // else the next match is the edge's: its handler takes the command
    }
  }
}

// Called from: main loop (command: a live note on a silent motor, its DIR set no later than
// dir_set, a Timer1 count). Brings the motor's first edge cfg::kTriggerLeadTicks from now
// through its own channel (Chan<M>::trigger: the compare that far past the channel's own
// timer, written a few cycles after reading it) with the count-off and busy bits clear, so its
// stub raises STEP on the match and its handler schedules the next edge from m.deadline.
// (arm() checks the time left twice, about 200 cycles, and wants kStartLeadTicks ahead.)
// First it waits until the motor's pulse width has passed since dir_set: the edge comes after
// the write in any case, and at the write itself when the channel's old value matched during
// it (its flag is taken once interrupts are on, the busy bit clear), so DIR's set-up holds
// whatever the lead; the next edge still comes a period after m.deadline. Interrupts off about
// 45 cycles, more while the emulator's settle (in trigger) waits on a sibling compare.
template <uint8_t M> void fire(uint16_t dir_set) {
  typedef Chan<M> C;
  Motor &m = g_motor[M];
  for (;;) {
    uint16_t t;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = TCNT1; }
    if ((uint16_t)(t - dir_set) >= m.pulse_ticks) break;
  }
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    const uint16_t t = TCNT1;
    C::trigger();
    // The match's board time, to the emulator's settle and Timer2's 8-cycle grid: the next
    // edge's phase only. g_time_base as now() extends Timer1 (at most 32,767 ticks old).
    const uint32_t base = g_time_base;
    m.deadline = base + (int16_t)((uint16_t)(t + cfg::kTriggerLeadTicks) - (uint16_t)base);
    GPIOR0 &= (uint8_t)~_BV(M);  // the match raises (no count-off)
    busy_clear<M>();
  }
}

// Called from: main loop. Channel operations by motor index.
struct Ops {
  bool (*arm)(uint32_t);
  void (*fire)(uint16_t);
  void (*busy)();
  void (*poke)();
};
template <uint8_t M> bool arm_m(uint32_t d) { return arm<M>(d); }
template <uint8_t M> void busy_m() { busy_set<M>(); }
#define SC_OPS(M) {arm_m<M>, fire<M>, busy_m<M>, poke<M>}
const Ops kOps[kMotors] = {
    SC_OPS(0), SC_OPS(1), SC_OPS(2), SC_OPS(3),
#if defined(__AVR_ATmega2560__)
    SC_OPS(4),
#endif
};

// Called from: main loop (command, start_move). Hands silent motor mi, its first deadline and
// period set, to its channel: its first edge on m.deadline, or as soon after as the channel can
// be armed.
void start(uint8_t mi) {
  Motor &m = g_motor[mi];
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_sounding |= (uint8_t)(1u << mi);  // its channel is busy while silent
  }
  // Held up past it (by the ISRs meanwhile): again, further ahead each time.
  for (uint16_t lead = cfg::kStartLeadTicks; !kOps[mi].arm(m.deadline); lead = (uint16_t)(lead + cfg::kStartLeadTicks))
    m.deadline = now() + lead;
}

// Called from: main loop. Motor mi takes period now, or timed at `at`. A silent motor is
// started here (its channel is off: nothing else touches it); a sounding one gets the command
// in its mailbox, and its channel's ISR takes it within microseconds (poke). Interrupts off
// at most about 30 cycles at a time, about 50 in fire().
bool command(uint8_t mi, uint32_t period, bool timed, uint32_t at) {
  Motor &m = g_motor[mi];
  const uint8_t bit = (uint8_t)(1u << mi);
  for (;;) {
    // An earlier command is taken within microseconds (unless the motor fell silent).
    while (m.cmd != kCmdNone && (g_sounding & bit)) {
    }
    if (!(g_sounding & bit)) break;
    m.cmd_period_q8 = period;  // the ISR reads the mailbox only once cmd is set
    m.cmd_at = at;
    bool posted = false;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      if (g_sounding & bit) {
        m.cmd = timed ? kCmdTimed : kCmdLive;
        posted = true;
      }
    }
    if (posted) {
      kOps[mi].poke();
      return true;
    }
  }
  m.cmd = kCmdNone;
  if (!timed && m.period_q8 == 0 && period != sc::kPeriodSilent) {
    // A live note on a silent motor: its first edge at once, a pulse width after DIR at least
    // (every supported driver's DIR set-up time).
    start_silent(m, period, 0);
    uint16_t dir_set;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      dir_set = TCNT1;
      g_sounding |= bit;
    }
    kOps[mi].fire(dir_set);
    return true;
  }
  const bool ok = apply(m, period, timed, at);
  if (m.period_q8 != 0) start(mi);
  return ok;
}

}  // namespace
}  // namespace sched

// Channel ISRs: one stub a motor (chip/stub.h), raising STEP through the pin chip/step_pin.h
// derives from the board table, then this file's handlers.
SC_MOTOR_VECTORS(SC_STEP_ENTRY)

// Timer0 compare A. Who: every 16,384 ticks (Timer0 counts ticks / 64; Arduino's millis()
// tick, its overflow, stays off). Moves board time's base on, so that Timer1's 16-bit count
// extends to 32 bits (about 40 cycles, interrupts on but for the two reads and the store).
ISR(TIMER0_COMPA_vect, ISR_NOBLOCK) {
  const uint32_t t = sched::now();
  ATOMIC_BLOCK(ATOMIC_FORCEON) { sched::g_time_base = t; }
}

namespace sched {

void init(uint8_t motor_count, const Wiring *wiring) {
  for (uint8_t i = 0; i < motor_count; ++i) {
    Motor &m = g_motor[i];
    const Wiring &w = wiring[i];
    pio::output(w.step, false);
    pio::output(w.dir, true);
    pio::input(w.min_switch, true);
    pio::input(w.max_switch, true);
    m.dir_port = pio::port_reg(w.dir.port);
    m.dir_mask = pio::mask(w.dir);
    m.sw_up_pin = w.max_switch.wired() ? pio::pin_reg(w.max_switch.port) : 0;
    m.sw_up_mask = pio::mask(w.max_switch);
    m.sw_down_pin = w.min_switch.wired() ? pio::pin_reg(w.min_switch.port) : 0;
    m.sw_down_mask = pio::mask(w.min_switch);
    m.flags = kUp | kArmed;
    m.period_q8 = 0;
    m.pulse_ticks = (uint8_t)(cfg::kPulseUsA4988 * (F_CPU / 1000000ul));
    Motion motion = {cfg::kDefaultTravelSteps, m.pulse_ticks, false, 0, 0};
    set_motion(i, motion);
  }
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_sounding = 0;
    GPIOR0 = 0;
    for (uint8_t i = 0; i < kMotors; ++i) kOps[i].busy();  // silent: every match returns at once
    // Normal mode (simavr times it exactly; phase-correct PWM, which Arduino's init() sets, it
    // does not), the prescalers held and reset so that the timers count in step.
    GTCCR = _BV(TSM) | _BV(PSRASY) | _BV(PSRSYNC);
    TCCR1A = 0;
    TCCR1B = _BV(CS10);  // CPU cycles
    TCCR1C = 0;
    TCNT1 = 0;
    TCCR2A = 0;
    TCCR2B = _BV(CS21);  // CPU cycles / 8
    TCNT2 = 0;
#if defined(__AVR_ATmega2560__)
    TCCR3A = 0;
    TCCR3B = _BV(CS30);  // CPU cycles
    TCCR3C = 0;
    TCNT3 = 0;
#endif
    GTCCR = 0;
    // How the other timer stands against Timer1 (both started on the same cycle on a real
    // chip; an emulator may start them a few cycles apart).
    const uint16_t t1 = TCNT1;
    const uint8_t t2 = TCNT2;  // read 4 cycles after TCNT1's low byte
    g_skew2 = (uint8_t)(t2 - (uint8_t)((uint16_t)(t1 + 4) >> 3));
#if defined(__AVR_ATmega2560__)
    {
      const uint16_t a = TCNT1;
      const uint16_t b = TCNT3;  // read 4 cycles after TCNT1's low byte
      g_skew3 = (uint16_t)(b - a - 4);
    }
#endif
    g_time_base = 0;
    // Every channel's interrupt stays on from here (a silent motor's matches return at once):
    // the virtual board never takes a flag raised while its interrupt was off.
    SC_CHANNEL_INTERRUPTS()
    TCCR0A = 0;
    TCCR0B = _BV(CS01) | _BV(CS00);  // ticks / 64: a compare every 16,384 ticks
    OCR0A = 0;
    TIFR0 = _BV(OCF0A);
    TIMSK0 = _BV(OCIE0A);
  }
}

void set_motion(uint8_t mi, const Motion &motion) {
  Motor &m = g_motor[mi];
  // Work out the new limits first: interrupts are off only for the stores.
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
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // the motor's ISR reads them (about 60 cycles)
    m.pulse_ticks = (uint8_t)motion.pulse_ticks;
    m.start_q8 = motion.start_period_q8;
    m.ramp_q8 = motion.ramp_q8;
    m.flags = (uint8_t)((m.flags & ~clear) | set);
    if (recentre) m.position = centre;
    m.limit_hi = hi;
    m.limit_lo = lo;
    m.travel_steps = motion.travel_steps;
  }
}

void poll() {
  while (g_queue.used) {
    const AtSlot &e = g_queue.front();
    if (!take_entry_now((int32_t)(e.at - now()), g_motor[e.motor].flags & kRestrike)) return;
    const AtSlot slot = e;
    g_queue.pop();
    if (!command(slot.motor, slot.period_q8, true, slot.at)) {
      g_count.late_motor = slot.motor;
      g_count.late_entries = (uint8_t)(g_count.late_entries + 1);
    }
  }
}

void silence(uint8_t mask) {
  mask &= (uint8_t)((1u << kMotors) - 1u);
  // Busy first (each an atomic sbi): no handler runs while the main loop does, and none enters
  // from here on; then the rest with interrupts on.
  uint8_t bit = 1;  // (a bit walked along, not 1 << i: no shift loop on the AVR)
  for (uint8_t i = 0; i < kMotors; ++i, bit = (uint8_t)(bit << 1))
    if (mask & bit) kOps[i].busy();
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_sounding &= (uint8_t)~mask;
    GPIOR0 &= (uint8_t)~mask;  // no visits
  }
  bit = 1;
  for (Motor *m = g_motor; m != g_motor + kMotors; ++m, bit = (uint8_t)(bit << 1)) {
    if (!(mask & bit)) continue;
    if (m->flags & kMove) m->move_end = sc::kMoveEndStopped;
    m->period_q8 = 0;
    m->flags &= (uint8_t)~(kRamp | kRestrike | kMove);
    m->cmd = kCmdNone;
  }
  g_queue.drop(mask);  // their queued entries with them
}

void silence_all() {
  silence((uint8_t)((1u << kMotors) - 1u));
  g_queue.clear();
}

void set_period(uint8_t mi, uint32_t period_q8) {
  if (period_q8 == sc::kPeriodSilent && !(g_sounding & (1u << mi))) {
    // Silence for a silent motor (the host's refresh sends one for every motor, in one frame a
    // note may follow at once): what command() and apply() do for it, without their clock
    // read and checks, about 30 cycles.
    Motor &m = g_motor[mi];
    m.cmd = kCmdNone;
    m.period_q8 = 0;
    m.flags &= (uint8_t)~(kRamp | kRestrike);
    return;
  }
  command(mi, period_q8, false, 0);
}

void set_period_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) { command(m, period_q8, true, at_ticks); }

uint8_t sounding() { return g_sounding; }

bool start_move(uint8_t mi, bool up, uint32_t steps, uint8_t move_flags, uint32_t period_q8, uint32_t at) {
  Motor &m = g_motor[mi];
  if (g_sounding & (uint8_t)(1u << mi)) return false;
  set_dir(m, up);
  m.move_left = steps;
  m.move_flags = move_flags;
  if ((move_flags & sc::kMoveToSwitch) && pressed_ahead(m, up)) {  // there already: no step
    m.move_end = sc::kMoveEndSwitch;
    return true;
  }
  m.flags = (uint8_t)((m.flags & ~(kRamp | kRestrike)) | kMove);
  m.cmd = kCmdNone;
  m.deadline = (int32_t)(at - now()) > (int32_t)cfg::kStartLeadTicks ? at : now() + cfg::kStartLeadTicks;
  m.deadline_frac = 0;
  m.period_q8 = period_q8;
  start(mi);
  return true;
}

void retune_move(uint8_t mi, uint32_t period_q8) {
  Motor &m = g_motor[mi];
  const uint8_t bit = (uint8_t)(1u << mi);
  while (m.cmd != kCmdNone && (g_sounding & bit)) {
  }
  m.cmd_period_q8 = period_q8;  // the ISR reads the mailbox only once cmd is set
  bool posted = false;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if ((g_sounding & bit) && (m.flags & kMove)) {
      m.cmd = kCmdLive;
      posted = true;
    }
  }
  if (posted) kOps[mi].poke();
}

bool move_state(uint8_t mi, uint32_t *left, uint8_t *end) {
  const Motor &m = g_motor[mi];
  bool moving;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // the motor's handler writes them
    moving = m.flags & kMove;
    *left = m.move_left;
    *end = m.move_end;
  }
  return moving;
}

void set_position(uint8_t mi, int32_t position) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { g_motor[mi].position = position; }  // its handler counts it
}

uint8_t queue_used() { return g_queue.used; }

void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) {
  g_queue.put(m, period_q8, at_ticks);
  poll();  // an entry due within kTakeTicks is taken at once
}

Counters counters() {
  Counters c;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // the motors' handlers write them
    c.late_edges = g_count.late_edges;
    c.motor_fault = g_count.motor_fault;
    c.late_entries = g_count.late_entries;
    c.late_motor = g_count.late_motor;
  }
  return c;
}

void reset_counters() {
  for (uint8_t i = 0; i < kMotors; ++i)
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { g_motor[i].reversals = 0; }  // its handler counts them
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_count.late_edges = 0;
    g_count.motor_fault = 0;
  }
}

void motor_status(uint8_t mi, sc::StatusMotor *out) {
  const Motor &m = g_motor[mi];
  const uint8_t bit = (uint8_t)(1u << mi);
  int32_t position;
  uint16_t reversals;
  uint8_t flags, sounding;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // the motor's handler writes them
    position = m.position;
    reversals = m.reversals;
    flags = m.flags;
    sounding = g_sounding;
  }
  out->position_steps = position;
  out->reversals = reversals;
  out->flags = (uint8_t)(((flags & kUp) ? sc::kMotorDirUp : 0) | ((sounding & bit) ? sc::kMotorSounding : 0) |
                         ((flags & kFault) ? sc::kMotorEndstopFault : 0));
}

}  // namespace sched

// scheduler.cpp: one timer compare channel per motor, and the motor table (AVR only).
#include "scheduler.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>
#include <util/delay.h>

#include "boards/board.h"
#include "config.h"
#include "hal.h"
#include "link.h"
#include "microstep.h"
#include "pin_io.h"
#include "step_driver.h"

namespace sched {
namespace {

const uint8_t kMotors = board::active::kMotorCount;

// Motor flags.
const uint8_t kUp = 0x01;          // DIR pin high: position counts up
const uint8_t kArmed = 0x02;       // the endstop may trigger a reversal
const uint8_t kActiveHigh = 0x04;  // switches read HIGH when pressed
const uint8_t kRamp = 0x08;        // onset ramp in progress
const uint8_t kFault = 0x10;       // switch found stuck: ignored from now on
const uint8_t kLimits = 0x20;      // soft limits on (travel configured)
const uint8_t kRestrike = 0x40;    // a timed note change waits for its time (restrike_at)

// Mailbox states (Motor::cmd).
const uint8_t kCmdNone = 0;
const uint8_t kCmdLive = 1;   // play cmd_period_q8 from now on
const uint8_t kCmdTimed = 2;  // ... exactly at cmd_at

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
};

Motor g_motor[kMotors];
// Bit m: motor m sounds, and its channel belongs to its ISR. Set by the main loop when it
// starts a silent motor, cleared by the ISR when the motor falls silent (or by stop-all).
volatile uint8_t g_sounding;
// Matches of motor m's channel still to come before its edge (its stub counts them down and
// clears bit m of GPIOR0 at the last); kWrapsVisit: the next match enters the handler (a
// command to take, or more matches than the count holds).
volatile uint8_t g_wraps[kMotors];
const uint8_t kWrapsVisit = 0x80;
volatile uint8_t g_wraps_then[kMotors];  // g_wraps once the count is out: 0 (the edge next) or kWrapsVisit
const uint16_t kFineTicks = 61440;       // arm() counts wraps exactly up to this far ahead
const uint8_t kRoughSpareWraps = 16;     // ... and further, ends a rough count this early
const uint8_t kRoughVisit = 0xFF;        // arm(): the handler at the next match
volatile uint32_t g_time_base;  // a recent board time (see now())
volatile uint16_t g_reversals;
volatile uint16_t g_late_edges;
volatile uint8_t g_motor_fault;
volatile uint8_t g_late_entries;  // timed entries made after their time (played at once)
volatile uint8_t g_late_motor;    // the last one's motor
// Timestamped entries (kMsgAt): a ring the main loop fills (hal::queue_at) and empties
// (poll()), each entry cfg::kTakeTicks before its time.
struct AtSlot {
  uint32_t at;
  uint32_t period_q8;
  uint8_t motor;
};
AtSlot g_q[cfg::kQueueSize];
uint8_t g_q_used, g_q_put_idx, g_q_take_idx;
uint8_t g_skew2;  // TCNT2 - TCNT1 / 8 (Timer2 ticks), set once at init
#if defined(__AVR_ATmega2560__)
uint16_t g_skew3;  // TCNT3 - TCNT1 (ticks), set once at init
#endif

// A timed strike on a sounding motor replaces an old edge due less than this before its time:
// both would sound as one doubled step (a note change on the old note's own grid, as in a
// legato melody, lands within a tick of an old edge).
const int32_t kStrikeSnapTicks = 512;

// From the stub's raise to the handler's first timer read (ticks): the stub's jump, the
// handler's sei and register saves (45 cycles by the disassembly; less is safe: a pulse is then
// a little longer than asked).
const uint8_t kStubToHandlerTicks = 40;

// Called from: anywhere. Board time in ticks (interrupts off for about 14 cycles): Timer1's
// count extended from g_time_base, a time at most 32,767 ticks old (Timer0's ISR moves it on
// every 16,384 ticks).
__attribute__((noinline)) uint32_t now() {
  uint32_t base;
  uint16_t lo;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    base = g_time_base;
    lo = TCNT1;
  }
  return base + (int16_t)(lo - (uint16_t)base);
}

// ---------------------------------------------------------------------------------------
// Channels. Motor m steps from compare channel m; its ISR (SC_STEP_ENTRY below) raises STEP
// as its third instruction when bit m of GPIOR0 is clear, and otherwise counts off a match
// that comes before the edge's (g_wraps) or enters the handler without raising (a command).
//
// Chan<m>: the channel's registers. Timer1 (and the Mega's Timer3) counts CPU cycles (16 bits,
// a wrap every 4.1 ms); the Uno's Timer2 counts cycles / 8 (8 bits, a wrap every 128 us). Every
// 16-bit register access runs with interrupts off (the timers' TEMP byte is shared).
template <uint8_t M> struct Chan;

// No flag is ever cleared by writing TIFR: the virtual board (simavr 1.6) clears every flag of
// a timer when any bit of its TIFR is written (its handler ignores the value), losing the other
// channels' matches. A match of an old compare value still waiting is let in while the busy
// bit is set, and returns at once. Writing an OCR register makes the virtual board reschedule
// the timer's compares, and one due in that instruction is lost: settle() first waits (32
// cycles at most) until a compare of the same timer due that soon has set its flag. A real
// chip loses neither; the checks cost a few cycles.
// Busy bit of motor m (an I/O bit, for sbic/sbi in its stub): set by the stub, cleared when the
// handler has armed the channel again; a match while it is set returns at once. Held up by
// other handlers nested in it, a handler may come to arming after its channel's next match
// (Timer2 wraps every 128 us). The Uno's four motors use GPIOR0 bits 4-7; the Mega's five use
// GPIOR0 bits 5-7 and PORTG bits 3-4 (PG3 and PG4 are not brought out on an Arduino Mega:
// their pull-ups are the bits).
#if defined(__AVR_ATmega2560__)
#define SC_BUSY_IO(M) ((M) < 3 ? 0x1E : 0x14)
#define SC_BUSY_BIT(M) ((M) < 3 ? (M) + 5 : (M))
static_assert(_SFR_IO_ADDR(PORTG) == 0x14 && _SFR_IO_ADDR(GPIOR0) == 0x1E, "busy bits");
#else
#define SC_BUSY_IO(M) 0x1E
#define SC_BUSY_BIT(M) ((M) + 4)
static_assert(_SFR_IO_ADDR(GPIOR0) == 0x1E, "busy bits");
#endif
template <uint8_t M> inline void busy_clear() { _SFR_IO8(SC_BUSY_IO(M)) &= (uint8_t)~_BV(SC_BUSY_BIT(M)); }

const uint8_t kSettleTicks = 32;
// Waits while the compare in `ocr` of the same timer is due within kSettleTicks and has not yet
// set its flag (`flag` in `tifr`). Interrupts off.
__attribute__((always_inline)) inline void settle16(volatile uint16_t &ocr, volatile uint16_t &tcnt, volatile uint8_t &tifr, uint8_t flag) {
  while (!(tifr & flag) && (uint16_t)(ocr + 1 - tcnt) < kSettleTicks) {
  }
}
__attribute__((always_inline)) inline void settle8(volatile uint8_t &ocr, volatile uint8_t &tcnt, volatile uint8_t &tifr, uint8_t flag) {
  while (!(tifr & flag) && (uint8_t)(ocr + 1 - tcnt) < (kSettleTicks >> 3)) {
  }
}

#define SC_AI inline __attribute__((always_inline))
// The virtual board (simavr 1.6) schedules a wrap's Timer1 compares when it processes the
// overflow, after the instruction the overflow fell in (up to 5 cycles), and drops a compare due
// before that: at OCR1x 0 or 1 a match is lost in some wraps (measured on both boards; 2 too by
// simavr's code, with the Mega's 5-cycle instructions), and its edge comes a wrap (4.1 ms) late
// (`ctest -R vboard_timer_quirks`; the Mega's Timer3 runs the same simavr code, and its
// compares are held to the same floor). No OCR1x is set below kOcr1Min: such an edge rises at
// most kOcr1Min cycles late (0.25 us, one edge in 16,000), its deadline kept. Timer2's compares
// come at least one tick (8 cycles) after its overflow, past any instruction.
const uint16_t kOcr1Min = 4;
SC_AI uint16_t ocr1(uint16_t v) { return v < kOcr1Min ? kOcr1Min : v; }
// Timer1 or Timer3 (N), compare X; SKEW: the timer's count less Timer1's (0 for Timer1).
#define SC_CHAN_16(M, N, X, SKEW, SIBS)                                                          \
  template <> struct Chan<M> {                                                                   \
    static const uint32_t kWrap = 65536ul;                                                       \
    typedef uint16_t Value;                                                                      \
    typedef uint16_t Snap;                                                                       \
    static SC_AI Value value(uint32_t d) { return ocr1((uint16_t)((uint16_t)d + (SKEW))); }      \
    static SC_AI Value read() { return OCR##N##X; }                                             \
    static SC_AI void write(Value v) { OCR##N##X = v; }                                         \
    static SC_AI Snap snap() { return N == 1 ? 0 : TCNT##N; }                                    \
    static SC_AI uint16_t until(uint16_t t, Snap tn) { const uint16_t a = (uint16_t)(OCR##N##X + 1 - (N == 1 ? t : tn)); return a ? a : 0xFFFF; } \
    static SC_AI uint8_t count(uint32_t half_on, uint16_t, uint16_t, uint16_t u) { return (uint8_t)((half_on - u) >> 16); } \
    static SC_AI void settle() { SIBS }                                                         \
    static SC_AI bool waiting() { return TIFR##N & _BV(OCF##N##X); }                            \
    static SC_AI uint16_t ahead() { return (uint16_t)(OCR##N##X - TCNT##N); }                   \
    static SC_AI void trigger() { SIBS OCR##N##X = ocr1((uint16_t)(TCNT##N + cfg::kTriggerLeadTicks)); } \
  };
#define SC_CHAN_T1(M, X, SIBS) SC_CHAN_16(M, 1, X, 0, SIBS)
#define SC_CHAN_T3(M, X, SIBS) SC_CHAN_16(M, 3, X, g_skew3, SIBS)
#define SC_CHAN_T2(M, X, SIBS)                                                                        \
  template <> struct Chan<M> {                                                                    \
    static const uint32_t kWrap = 2048ul;                                                         \
    typedef uint8_t Value;                                                                        \
    typedef uint8_t Snap;                                                                         \
    static SC_AI Value value(uint32_t d) { return (uint8_t)(((uint16_t)d >> 3) + g_skew2); }     \
    static SC_AI Value read() { return OCR2##X; }                                                \
    static SC_AI void write(Value v) { OCR2##X = v; }                                            \
    static SC_AI uint8_t snap() { return TCNT2; }                                               \
    static SC_AI uint16_t until(uint16_t, uint8_t tcnt2) { const uint8_t a = (uint8_t)(OCR2##X + 1 - tcnt2); return a ? (uint16_t)a << 3 : (uint16_t)kWrap; } \
    static SC_AI uint8_t count(uint32_t, uint16_t d16, uint16_t t, uint16_t u) { return (uint8_t)((uint16_t)(d16 - t - u + 1024u) >> 11); } \
    static SC_AI void settle() { SIBS }                                                         \
    static SC_AI bool waiting() { return TIFR2 & _BV(OCF2##X); }                                 \
    static SC_AI uint16_t ahead() { return (uint16_t)((uint8_t)(OCR2##X - TCNT2)) << 3; }        \
    static SC_AI void trigger() { SIBS OCR2##X = (uint8_t)(TCNT2 + (cfg::kTriggerLeadTicks >> 3)); } \
  };

#define SC_S1(X) settle16(OCR1##X, TCNT1, TIFR1, _BV(OCF1##X));
#define SC_S2(X) settle8(OCR2##X, TCNT2, TIFR2, _BV(OCF2##X));
#if defined(__AVR_ATmega2560__)
// X, Y, Z: Timer1 compare A, B, C; E0, E1: Timer3 compare A, B (16 bits: a match to count off
// every 4.1 ms). From 2026-12-01 to 12-02 E0 and E1 were on Timer2 (vectors 13 and 14, ahead of
// the UART's 25 in priority, where Timer3's 32 and 33 come after it: its edges waited behind a
// byte's ISR, 28 cycles off then). But an 8-bit Timer2 channel counts off a match every 128 us
// (26 cycles off, 32 at the last), and those held the other motors' edges up: at full line speed
// the worst note's p99 was 1.80-2.47 us on Timer2, 1.32-1.57 us since (18 runs), the worst
// motor's 1.49-1.88 us then, 1.08-1.38 since (each note's own grid, one offset per note).
SC_CHAN_T1(0, A, SC_S1(B) SC_S1(C))
SC_CHAN_T1(1, B, SC_S1(A) SC_S1(C))
SC_CHAN_T1(2, C, SC_S1(A) SC_S1(B))
#define SC_S3(X) settle16(OCR3##X, TCNT3, TIFR3, _BV(OCF3##X));
SC_CHAN_T3(3, A, SC_S3(B))
SC_CHAN_T3(4, B, SC_S3(A))
#else
// X, Y: Timer1 compare A, B; Z, A: Timer2 compare A, B.
SC_CHAN_T1(0, A, SC_S1(B))
SC_CHAN_T1(1, B, SC_S1(A))
SC_CHAN_T2(2, A, SC_S2(B))
SC_CHAN_T2(3, B, SC_S2(A))
#endif
static_assert(kMotors <= 5, "one compare channel per motor, five at most");


// Step<m>: motor m's STEP pin, checked against the board table. In the I/O space (sbi/cbi,
// atomic) except the Mega's Z on PORTL, whose read-modify-write runs with interrupts off.
template <uint8_t M> struct Step;
constexpr bool step_is(uint8_t m, char port, uint8_t bit) {
  return board::active::kMotors[m].step.port == port && board::active::kMotors[m].step.bit == bit;
}
#define SC_STEP_IO(M, PORT, LETTER, BIT)                                                 \
  static_assert(step_is(M, LETTER, BIT), "STEP pin of motor " #M " is not " #LETTER #BIT); \
  template <> struct Step<M> {                                                           \
    static inline void raise() { PORT |= _BV(BIT); }                                     \
    static inline void lower() { PORT &= (uint8_t)~_BV(BIT); }                           \
  };
#define SC_STEP_MEM(M, PORT, LETTER, BIT)                                                \
  static_assert(step_is(M, LETTER, BIT), "STEP pin of motor " #M " is not " #LETTER #BIT); \
  template <> struct Step<M> {                                                           \
    static inline void raise() { ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { PORT |= _BV(BIT); } } \
    static inline void lower() { ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { PORT &= (uint8_t)~_BV(BIT); } } \
  };
#if defined(__AVR_ATmega2560__)
SC_STEP_IO(0, PORTF, 'F', 0)
SC_STEP_IO(1, PORTF, 'F', 6)
SC_STEP_MEM(2, PORTL, 'L', 3)
SC_STEP_IO(3, PORTA, 'A', 4)
SC_STEP_IO(4, PORTC, 'C', 1)
#else
SC_STEP_IO(0, PORTD, 'D', 2)
SC_STEP_IO(1, PORTD, 'D', 3)
SC_STEP_IO(2, PORTD, 'D', 4)
SC_STEP_IO(3, PORTB, 'B', 4)
#endif

// ---------------------------------------------------------------------------------------
// Motor logic. Runs in motor m's own context: its channel ISR (interrupts on), or the main
// loop while the motor is silent (its channel off). Nothing else touches the motor then.

// Position, endstop bounce-back and soft limits after one step of m; a reversal turns DIR
// before the motor's next step.
__attribute__((always_inline)) inline void account_step(Motor &m) {
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
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { *m.dir_port ^= m.dir_mask; }  // other motors share the port
    g_reversals = (uint16_t)(g_reversals + 1);
  }
}

// Next deadline of m after the step at m.deadline: one period on (fraction carried), the
// onset ramp shortening the period step by step; a pending restrike lands exactly on its time
// instead, with the new period from there (0: a timed silence, before its first edge at or
// after the time).
__attribute__((always_inline)) inline void next_deadline(Motor &m) {
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
  // nothing about which end the carriage is at: the position decides).
  if (sw && m.sw_up_pin != m.sw_down_pin && drv::switch_pressed((*sw & mask) != 0, m.flags & kActiveHigh)) up = !up;
  return up;
}

// Sets DIR (other motors share the port: the write runs with interrupts off).
void set_dir(Motor &m, bool up) {
  if (up == (bool)(m.flags & kUp) && ((*m.dir_port & m.dir_mask) != 0) == up) return;
  if (up) m.flags |= kUp;
  else m.flags &= (uint8_t)~kUp;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
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
    set_dir(m, start_up(m));
    m.deadline = timed ? at : soonest;
    start_period(m, period);
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
  } else if ((int32_t)(m.deadline - at) >= -kStrikeSnapTicks) {
    // The next edge not before the time, or just before it: strike on it.
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

// Takes the command in m's mailbox.
void take_command(uint8_t mi, Motor &m) {
  const bool timed = m.cmd == kCmdTimed;
  m.cmd = kCmdNone;
  if (!apply(m, m.cmd_period_q8, timed, m.cmd_at)) {
    g_late_motor = mi;
    g_late_entries = (uint8_t)(g_late_entries + 1);
  }
}

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
      Step<M>::lower();
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
      Step<M>::raise();
      raised = TCNT1;
    }
    g_late_edges = (uint16_t)(g_late_edges + 1);
    edge = true;
  }
}

// Called from: main loop, after a command was left in a sounding motor's mailbox. Brings
// the channel's ISR (a visit) within kTriggerLeadTicks, or at its next match when that one
// would only be counted, unless the motor's next edge is due within kVisitMarginTicks: then
// that edge's handler takes the command (a visit that close, held up by the handlers nested in
// it, came to arming after the edge: edges 11-120 us late before a timed chord change at full
// line speed). A timed change due before that edge (or just after it: a strike would replace
// it) is brought at once all the same. Interrupts off for about 20 cycles at a time.
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

// Called from: main loop. Channel operations by motor index.
struct Ops {
  bool (*arm)(uint32_t);
  void (*busy)();
  void (*poke)();
};
template <uint8_t M> bool arm_m(uint32_t d) { return arm<M>(d); }
template <uint8_t M> void busy_m() { _SFR_IO8(SC_BUSY_IO(M)) |= _BV(SC_BUSY_BIT(M)); }
#define SC_OPS(M) {arm_m<M>, busy_m<M>, poke<M>}
const Ops kOps[kMotors] = {
    SC_OPS(0), SC_OPS(1), SC_OPS(2), SC_OPS(3),
#if defined(__AVR_ATmega2560__)
    SC_OPS(4),
#endif
};

// Called from: main loop. Motor mi takes period now, or timed at `at`. A silent motor is
// started here (its channel is off: nothing else touches it); a sounding one gets the command
// in its mailbox, and its channel's ISR takes it within microseconds (poke). Interrupts off
// at most about 30 cycles at a time.
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
  const bool ok = apply(m, period, timed, at);
  if (m.period_q8 == 0) return ok;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_sounding |= bit;  // its channel is busy while silent
  }
  // Held up past it (by the ISRs meanwhile): again, further ahead each time.
  for (uint16_t lead = cfg::kStartLeadTicks; !kOps[mi].arm(m.deadline); lead = (uint16_t)(lead + cfg::kStartLeadTicks))
    m.deadline = now() + lead;
  return ok;
}

}  // namespace
}  // namespace sched

// Channel ISRs. Who: motor m's compare match. The stub returns at once while the motor's busy
// bit is set. With bit m of GPIOR0 clear it raises STEP (13 cycles after the match), sets the
// busy bit and jumps to the motor's handler, which turns interrupts back on as its first
// instruction (interrupts off 19 cycles in all, by the instruction count). With it set, the match comes before the
// edge's: the stub counts it off g_wraps (interrupts off 29 cycles, 37 at the last, by the
// instruction count) and clears the bit at the last, or enters the handler (kWrapsVisit).
#define SC_STEP_ENTRY(M, VECT, RAISE_ASM)                                                               \
  extern "C" void __vector_sc_edge##M(void) __attribute__((interrupt, used, externally_visible));        \
  extern "C" void __vector_sc_visit##M(void) __attribute__((interrupt, used, externally_visible));       \
  extern "C" void __vector_sc_edge##M(void) { sched::serve<M>(true); }                                 \
  extern "C" void __vector_sc_visit##M(void) { sched::serve<M>(false); }                               \
  ISR(VECT, ISR_NAKED) {                                                                               \
    __asm__ __volatile__("sbic %[bio], %[bb]\n\t"                                                      \
                         "reti\n\t"                                                                   \
                         "sbic %[gp], %[m]\n\t"                                                        \
                         "rjmp 2f\n\t" RAISE_ASM                                                       \
                         "sbi %[bio], %[bb]\n\t"                                                       \
                         "jmp %x[edge]\n\t"                                                            \
                         "2:\n\t"                                                                   \
                         "push r24\n\t"                                                             \
                         "in r24, __SREG__\n\t"                                                     \
                         "push r24\n\t"                                                             \
                         "lds r24, %[wraps]\n\t"                                                    \
                         "sbrc r24, 7\n\t"                                                          \
                         "rjmp 4f\n\t"                                                              \
                         "dec r24\n\t"                                                              \
                         "sts %[wraps], r24\n\t"                                                    \
                         "brne 3f\n\t"                                                              \
                         "lds r24, %[then]\n\t"                                                     \
                         "sts %[wraps], r24\n\t"                                                    \
                         "sbrs r24, 7\n\t"                                                          \
                         "cbi %[gp], %[m]\n\t"                                                      \
                         "3:\n\t"                                                                   \
                         "pop r24\n\t"                                                              \
                         "ori r24, 0x80\n\t"                                                        \
                         "out __SREG__, r24\n\t"                                                    \
                         "pop r24\n\t"                                                              \
                         "reti\n\t"                                                                 \
                         "4:\n\t"                                                                   \
                         "pop r24\n\t"                                                              \
                         "out __SREG__, r24\n\t"                                                    \
                         "pop r24\n\t"                                                              \
                         "sbi %[bio], %[bb]\n\t"                                                    \
                         "jmp %x[visit]\n\t" ::[gp] "I"(_SFR_IO_ADDR(GPIOR0)),                          \
                         [m] "I"(M), [bio] "I"(SC_BUSY_IO(M)), [bb] "I"(SC_BUSY_BIT(M)),                   \
                         [wraps] "i"(&sched::g_wraps[M]), [then] "i"(&sched::g_wraps_then[M]), [visit] "i"(__vector_sc_visit##M), \
                         [edge] "i"(__vector_sc_edge##M));                                                \
  }
#define SC_RAISE_IO(PORT, BIT) "sbi " #PORT ", " #BIT "\n\t"
#if defined(__AVR_ATmega2560__)
// PORTF 0x11, PORTA 0x02, PORTC 0x08 (I/O addresses); PINL at 0x109 (data space).
static_assert(_SFR_IO_ADDR(PORTF) == 0x11 && _SFR_IO_ADDR(PORTA) == 0x02 && _SFR_IO_ADDR(PORTC) == 0x08, "ports");
static_assert(_SFR_MEM_ADDR(PINL) == 0x109, "PINL");
SC_STEP_ENTRY(0, TIMER1_COMPA_vect, SC_RAISE_IO(0x11, 0))
SC_STEP_ENTRY(1, TIMER1_COMPB_vect, SC_RAISE_IO(0x11, 6))
// Z: PL3, raised by writing its bit to PINL (0x109: a write of 1 toggles the port bit; STEP is
// low before every raise), which needs no SREG save.
SC_STEP_ENTRY(2, TIMER1_COMPC_vect, "push r24\n\tldi r24, 0x08\n\tsts 0x109, r24\n\tpop r24\n\t")
SC_STEP_ENTRY(3, TIMER3_COMPA_vect, SC_RAISE_IO(0x02, 4))
SC_STEP_ENTRY(4, TIMER3_COMPB_vect, SC_RAISE_IO(0x08, 1))
#else
// PORTD 0x0B, PORTB 0x05 (I/O addresses).
static_assert(_SFR_IO_ADDR(PORTD) == 0x0B && _SFR_IO_ADDR(PORTB) == 0x05, "ports");
SC_STEP_ENTRY(0, TIMER1_COMPA_vect, SC_RAISE_IO(0x0B, 2))
SC_STEP_ENTRY(1, TIMER1_COMPB_vect, SC_RAISE_IO(0x0B, 3))
SC_STEP_ENTRY(2, TIMER2_COMPA_vect, SC_RAISE_IO(0x0B, 4))
SC_STEP_ENTRY(3, TIMER2_COMPB_vect, SC_RAISE_IO(0x05, 4))
#endif

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
#if defined(__AVR_ATmega2560__)
    TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B) | _BV(OCIE1C);
    TIMSK3 = _BV(OCIE3A) | _BV(OCIE3B);
#else
    TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B);
    TIMSK2 = _BV(OCIE2A) | _BV(OCIE2B);
#endif
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
  while (g_q_used) {
    const AtSlot &e = g_q[g_q_take_idx];
    const int32_t ahead = (int32_t)(e.at - now());
    if (ahead > (int32_t)cfg::kTakeTicks) return;
    const Motor &m = g_motor[e.motor];
    // A motor holding a timed change still to come takes the next once that is its next edge.
    if ((m.flags & kRestrike) && ahead > (int32_t)cfg::kStartLeadTicks) return;
    const AtSlot slot = e;
    g_q_take_idx = (uint8_t)(g_q_take_idx + 1 == cfg::kQueueSize ? 0 : g_q_take_idx + 1);
    --g_q_used;
    if (!command(slot.motor, slot.period_q8, true, slot.at)) {
      g_late_motor = slot.motor;
      g_late_entries = (uint8_t)(g_late_entries + 1);
    }
  }
}

void silence_all() {
  // Busy first (each an atomic sbi): no handler runs while the main loop does, and none enters
  // from here on; then the rest with interrupts on.
  for (uint8_t i = 0; i < kMotors; ++i) kOps[i].busy();
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_sounding = 0;
    GPIOR0 &= (uint8_t)~((1u << kMotors) - 1u);  // no visits
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    g_motor[i].period_q8 = 0;
    g_motor[i].flags &= (uint8_t)~(kRamp | kRestrike);
    g_motor[i].cmd = kCmdNone;
  }
  g_q_used = 0;  // the queue's entries with them
  g_q_take_idx = g_q_put_idx;
}

}  // namespace sched

namespace hal {

uint32_t now_ticks() { return sched::now(); }

void set_period(uint8_t m, uint32_t period_q8) {
  // A driver just woken gets 5 us before DIR moves (a TB6600 wants ENA that long before DIR).
  if (period_q8 != sc::kPeriodSilent && drivers::enable_for(m)) _delay_us(6);
  sched::command(m, period_q8, false, 0);
}

uint8_t queue_used() { return sched::g_q_used; }

void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) {
  if (period_q8 != sc::kPeriodSilent) drivers::enable_for(m);
  sched::AtSlot &slot = sched::g_q[sched::g_q_put_idx];
  slot.at = at_ticks;
  slot.period_q8 = period_q8;
  slot.motor = m;
  sched::g_q_put_idx = (uint8_t)(sched::g_q_put_idx + 1 == cfg::kQueueSize ? 0 : sched::g_q_put_idx + 1);
  ++sched::g_q_used;
  sched::poll();  // an entry due within kTakeTicks is taken at once
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
  const sched::Motor &mo = sched::g_motor[m];
  const uint8_t bit = (uint8_t)(1u << m);
  int32_t position;
  uint8_t flags, sounding;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // the motor's ISR writes them
    position = mo.position;
    flags = mo.flags;
    sounding = sched::g_sounding;
  }
  out->position_steps = position;
  out->flags = (uint8_t)(((flags & sched::kUp) ? sc::kMotorDirUp : 0) | ((sounding & bit) ? sc::kMotorSounding : 0) |
                         ((flags & sched::kFault) ? sc::kMotorEndstopFault : 0));
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

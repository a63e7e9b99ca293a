// channel.h: motor m's timer compare channel (Chan<m>) and busy bit, per chip family
// (channels_m328p.h, channels_m2560.h). Included by the step path's one translation unit
// (scheduler.cpp), which holds their ISRs, and by arm.h, which arms them. AVR only.
//
// Timer1 (and the Mega's Timer3) counts CPU cycles (16 bits, a wrap every 4.1 ms); the Uno's
// Timer2 counts cycles / 8 (8 bits, a wrap every 128 us). Every 16-bit register access runs
// with interrupts off (the timers' TEMP byte is shared).
//
// Busy bit of motor m (an I/O bit, for sbic/sbi in its stub): set by the stub, cleared when the
// handler has armed the channel again; a match while it is set returns at once. Held up by
// other handlers nested in it, a handler may come to arming after its channel's next match.
#ifndef STEPCHOIR_CHIP_CHANNEL_H
#define STEPCHOIR_CHIP_CHANNEL_H

#include <avr/io.h>
#include <stdint.h>

#include "chip/emulator.h"
#include "chip/step_pin.h"
#include "config.h"

namespace sched {
namespace {

uint8_t g_skew2;  // TCNT2 - TCNT1 / 8 (Timer2 ticks), set once at init
#if defined(__AVR_ATmega2560__)
uint16_t g_skew3;  // TCNT3 - TCNT1 (ticks), set once at init
#endif

// Chan<m>: the channel's registers.
//   value(d)   the compare value for board time d;   read(), write(v): the compare register
//   snap()     the channel's own timer (with Timer1 read in the same critical section)
//   until(t,s) ticks from that read to the channel's next match
//   count(...) the matches before d's own, from the same read
//   settle()   the emulator's wait before a compare write (emulator.h, 2)
//   waiting()  the compare flag; ahead(): ticks to the next match; trigger(): a match soon
template <uint8_t M> struct Chan;

#define SC_AI inline __attribute__((always_inline))
// Timer1 or Timer3 (N), compare X; SKEW: the timer's count less Timer1's (0 for Timer1);
// SIBS: settle() on the timer's other compares.
#define SC_CHAN_16(M, N, X, SKEW, SIBS)                                                          \
  template <> struct Chan<M> {                                                                   \
    static const uint32_t kWrap = 65536ul;                                                       \
    typedef uint16_t Value;                                                                      \
    typedef uint16_t Snap;                                                                       \
    static SC_AI Value value(uint32_t d) { return emu::ocr16((uint16_t)((uint16_t)d + (SKEW))); } \
    static SC_AI Value read() { return OCR##N##X; }                                             \
    static SC_AI void write(Value v) { OCR##N##X = v; }                                         \
    static SC_AI Snap snap() { return N == 1 ? 0 : TCNT##N; }                                    \
    static SC_AI uint16_t until(uint16_t t, Snap tn) { const uint16_t a = (uint16_t)(OCR##N##X + 1 - (N == 1 ? t : tn)); return a ? a : 0xFFFF; } \
    static SC_AI uint8_t count(uint32_t half_on, uint16_t, uint16_t, uint16_t u) { return (uint8_t)((half_on - u) >> 16); } \
    static SC_AI void settle() { SIBS }                                                         \
    static SC_AI bool waiting() { return TIFR##N & _BV(OCF##N##X); }                            \
    static SC_AI uint16_t ahead() { return (uint16_t)(OCR##N##X - TCNT##N); }                   \
    static SC_AI void trigger() { SIBS OCR##N##X = emu::ocr16((uint16_t)(TCNT##N + cfg::kTriggerLeadTicks)); } \
  };
#define SC_CHAN_T1(M, X, SIBS) SC_CHAN_16(M, 1, X, 0, SIBS)
#define SC_CHAN_T3(M, X, SIBS) SC_CHAN_16(M, 3, X, g_skew3, SIBS)
// Timer2, compare X (8 bits, cycles / 8).
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
#define SC_S1(X) emu::settle16(OCR1##X, TCNT1, TIFR1, _BV(OCF1##X));
#define SC_S2(X) emu::settle8(OCR2##X, TCNT2, TIFR2, _BV(OCF2##X));
#define SC_S3(X) emu::settle16(OCR3##X, TCNT3, TIFR3, _BV(OCF3##X));

}  // namespace
}  // namespace sched

#if defined(__AVR_ATmega2560__)
#include "chip/channels_m2560.h"
#else
#include "chip/channels_m328p.h"
#endif

namespace sched {
namespace {
static_assert(board::active::kMotorCount <= 5, "one compare channel per motor, five at most");
template <uint8_t M> SC_AI void busy_set() { _SFR_IO8(SC_BUSY_IO(M)) |= _BV(SC_BUSY_BIT(M)); }
template <uint8_t M> SC_AI void busy_clear() { _SFR_IO8(SC_BUSY_IO(M)) &= (uint8_t)~_BV(SC_BUSY_BIT(M)); }
}  // namespace
}  // namespace sched

#endif  // STEPCHOIR_CHIP_CHANNEL_H

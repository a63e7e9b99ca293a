// channels_m328p.h: the Uno's (ATmega328P) four motors on four compare channels. Included by
// chip/channel.h only.
//   X, Y: Timer1 compare A, B (16 bits);  Z, A: Timer2 compare A, B (8 bits, cycles / 8).
// Busy bits: GPIOR0 bits 4-7 (bits 0-3: the stubs' count-off flags, one a motor).
#ifndef STEPCHOIR_CHIP_CHANNELS_M328P_H
#define STEPCHOIR_CHIP_CHANNELS_M328P_H

#define SC_BUSY_IO(M) 0x1E
#define SC_BUSY_BIT(M) ((M) + 4)
static_assert(_SFR_IO_ADDR(GPIOR0) == 0x1E, "busy bits");

namespace sched {
namespace {
SC_CHAN_T1(0, A, SC_S1(B))
SC_CHAN_T1(1, B, SC_S1(A))
SC_CHAN_T2(2, A, SC_S2(B))
SC_CHAN_T2(3, B, SC_S2(A))
}  // namespace
}  // namespace sched

// Motor -> its channel's interrupt vector (SC_STEP_ENTRY in scheduler.cpp expands X for each).
#define SC_MOTOR_VECTORS(X) X(0, TIMER1_COMPA_vect) X(1, TIMER1_COMPB_vect) X(2, TIMER2_COMPA_vect) X(3, TIMER2_COMPB_vect)
// Each channel's compare interrupt (TIMSKn), on from init.
#define SC_CHANNEL_INTERRUPTS() \
  TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B); \
  TIMSK2 = _BV(OCIE2A) | _BV(OCIE2B);

#endif  // STEPCHOIR_CHIP_CHANNELS_M328P_H

// channels_m2560.h: the Mega's (ATmega2560) five motors on five compare channels. Included by
// chip/channel.h only.
//   X, Y, Z: Timer1 compare A, B, C;  E0, E1: Timer3 compare A, B (16 bits both: a 16-bit
//   channel counts off a match every 4.1 ms, where an 8-bit Timer2 channel would every 128 us;
//   docs/decisions/ says why).
// Busy bits: GPIOR0 bits 5-7 for X, Y, Z and PORTG bits 3-4 for E0, E1 (PG3 and PG4 are not
// brought out on an Arduino Mega: their pull-ups are the bits).
#ifndef STEPCHOIR_CHIP_CHANNELS_M2560_H
#define STEPCHOIR_CHIP_CHANNELS_M2560_H

#define SC_BUSY_IO(M) ((M) < 3 ? 0x1E : 0x14)
#define SC_BUSY_BIT(M) ((M) < 3 ? (M) + 5 : (M))
static_assert(_SFR_IO_ADDR(PORTG) == 0x14 && _SFR_IO_ADDR(GPIOR0) == 0x1E, "busy bits");

namespace sched {
namespace {
SC_CHAN_T1(0, A, SC_S1(B) SC_S1(C))
SC_CHAN_T1(1, B, SC_S1(A) SC_S1(C))
SC_CHAN_T1(2, C, SC_S1(A) SC_S1(B))
SC_CHAN_T3(3, A, SC_S3(B))
SC_CHAN_T3(4, B, SC_S3(A))
}  // namespace
}  // namespace sched

// Motor -> its channel's interrupt vector (SC_STEP_ENTRY in scheduler.cpp expands X for each).
#define SC_MOTOR_VECTORS(X) \
  X(0, TIMER1_COMPA_vect) X(1, TIMER1_COMPB_vect) X(2, TIMER1_COMPC_vect) X(3, TIMER3_COMPA_vect) X(4, TIMER3_COMPB_vect)
// Each channel's compare interrupt (TIMSKn), on from init.
#define SC_CHANNEL_INTERRUPTS() \
  TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B) | _BV(OCIE1C); \
  TIMSK3 = _BV(OCIE3A) | _BV(OCIE3B);

#endif  // STEPCHOIR_CHIP_CHANNELS_M2560_H

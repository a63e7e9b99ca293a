// timer_quirks.c: tiny ATmega328P program measuring three ways the virtual board (simavr 1.6)
// differs from the datasheet, all met by the firmware: a TIFR write clears every set flag of the
// timer; a waiting interrupt is taken two instructions after sei; and a Timer1 compare at OCR1A
// 0 or 1 is lost in a wrap whose overflow falls inside a multi-cycle instruction.
//
// Each finding is a report: X DIR (PD5) and Y DIR (PD6) set to two bits, then Z DIR (PD7) toggled.
// Interrupts are off but in the windows below (and to let the ISR in after each). Timer2 runs in
// normal mode, prescaler 8.
// - Reports 0 and 1: OCF2A and OCF2B of TIFR2, before and after TIFR2 = _BV(OCF2B), with both
//   set (OCR2A and OCR2B passed). The datasheet clears only the flag written as one.
// - Reports 2-4: with OCIE2A on and its flag pending while I = 0, `sei`, 1, 2 or 3 nops, `cli`;
//   X DIR = the compare ISR ran in that window (Y DIR low). The datasheet runs one instruction
//   after `sei` before a waiting interrupt is taken.
// - Reports 5 and 6: Timer1 in normal mode, prescaler 1, OCR1A 0 (report 5) and then 16 (report
//   6), over kWraps wraps while the main code runs rcall and ret (3 and 4 cycles); X DIR = fewer
//   compare A matches than overflows. The datasheet matches once a wrap at any OCR1A. simavr 1.6
//   schedules a wrap's compares when it processes the overflow, after the instruction the
//   overflow fell in, and drops a compare due before that (avr_timer_tov: comp_cycles <
//   cycle - when).
// check_timer_quirks.py reads the trace.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>

#include "report.h"

#define BOTH (_BV(OCF2A) | _BV(OCF2B))

volatile uint8_t g_ran;

ISR(TIMER2_COMPA_vect) { g_ran = 1; }

// Leaves the compare A interrupt pending with I = 0: a fresh flag, raised while it is enabled.
static void pend(void) {
  g_ran = 0;
  TIFR2 = _BV(OCF2A);
  while (!(TIFR2 & _BV(OCF2A))) {
  }
}

// One window, sei + the nops + cli, as one asm statement (nothing else in it); then the ISR
// is let in (if still waiting) for the next window.
#define WINDOW(nops)                                                  \
  do {                                                                \
    pend();                                                           \
    __asm__ __volatile__("sei\n\t" nops "cli\n\t" ::: "memory");      \
    report(g_ran, 0);                                                 \
    sei();                                                            \
    for (uint8_t i = 0; i < 100 && !g_ran; ++i) {                     \
    }                                                                 \
    cli();                                                            \
  } while (0)

// Reports 5 and 6: matches of Timer1 compare A and Timer1 overflows.
volatile uint16_t g_comp1, g_ovf1;
ISR(TIMER1_COMPA_vect) { ++g_comp1; }
ISR(TIMER1_OVF_vect) { ++g_ovf1; }
static const uint16_t kWraps = 120;  // 7.9 M cycles: about 0.5 s of board time

// Counts compare A matches against overflows at `ocr` over kWraps wraps, the main code in calls
// and returns only; X DIR = some match was lost.
static void wraps_at(uint16_t ocr) {
  TIMSK1 = 0;
  TCCR1B = 0;
  TCNT1 = 0x8000;
  OCR1A = ocr;
  g_comp1 = 0;
  g_ovf1 = 0;
  TIFR1 = _BV(OCF1A) | _BV(TOV1);
  TIMSK1 = _BV(OCIE1A) | _BV(TOIE1);
  TCCR1B = _BV(CS10);
  sei();
  uint16_t ovf;
  do {
    __asm__ __volatile__("rcall 1f\n\trjmp 2f\n\t1: ret\n\t2:\n\t" ::: "memory");
    cli();
    ovf = g_ovf1;
    sei();
  } while (ovf < kWraps);
  // The last wrap's match (one cycle or 17 after its overflow) is let in.
  for (uint8_t i = 0; i < 20; ++i) {
    __asm__ __volatile__("nop");
  }
  cli();
  TIMSK1 = 0;
  report(g_comp1 < g_ovf1, 0);
}

int main(void) {
  DDRD = _BV(PD5) | _BV(PD6) | _BV(PD7);
  // Flags: both compares passed, no overflow yet (Timer2 from 0, 256 ticks = 2,048 cycles).
  OCR2A = 10;
  OCR2B = 20;
  TIFR2 = _BV(TOV2) | BOTH;
  TCCR2B = _BV(CS21);
  while ((TIFR2 & BOTH) != BOTH && TCNT2 < 200) {
  }
  const uint8_t before = TIFR2;
  TIFR2 = _BV(OCF2B);
  const uint8_t after = TIFR2;
  report(before & _BV(OCF2A), before & _BV(OCF2B));
  report(after & _BV(OCF2A), after & _BV(OCF2B));
  // Latency: the flag comes on its own, OCR2A's tick once a timer turn (2,048 cycles).
  TIMSK2 = _BV(OCIE2A);
  WINDOW("nop\n\t");
  WINDOW("nop\n\tnop\n\t");
  WINDOW("nop\n\tnop\n\tnop\n\t");
  TIMSK2 = 0;
  wraps_at(0);
  wraps_at(16);
  for (;;) {
  }
}

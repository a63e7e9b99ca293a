// timer_quirks.c: tiny ATmega328P program measuring two ways the virtual board (simavr 1.6) differs
// from the datasheet, both met by the firmware: its arm() clears OCF1A by a TIFR1 write, and its
// burst() lets waiting interrupts in with sei, nop, cli.
//
// Each finding is a report: X DIR (PD5) and Y DIR (PD6) set to two bits, then Z DIR (PD7) toggled.
// Interrupts are off but in the windows below (and to let the ISR in after each). Timer2 runs in
// normal mode, prescaler 8.
// - Reports 0 and 1: OCF2A and OCF2B of TIFR2, before and after TIFR2 = _BV(OCF2B), with both
//   set (OCR2A and OCR2B passed). The datasheet clears only the flag written as one.
// - Reports 2-4: with OCIE2A on and its flag pending while I = 0, `sei`, 1, 2 or 3 nops, `cli`;
//   X DIR = the compare ISR ran in that window (Y DIR low). The datasheet runs one instruction
//   after `sei` before a waiting interrupt is taken.
// check_timer_quirks.py reads the trace.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>

#define BOTH (_BV(OCF2A) | _BV(OCF2B))

volatile uint8_t g_ran;

ISR(TIMER2_COMPA_vect) { g_ran = 1; }

// One report: the two bits on X and Y DIR, then the mark on Z DIR.
static void report(uint8_t x, uint8_t y) {
  uint8_t d = PORTD & (uint8_t)~(_BV(PD5) | _BV(PD6));
  if (x) d |= _BV(PD5);
  if (y) d |= _BV(PD6);
  PORTD = d;
  PIND = _BV(PD7);
}

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
  for (;;) {
  }
}

// compare_lead.c: tiny ATmega328P program measuring how the virtual board (simavr) times a Timer1
// compare armed a few ticks ahead, the way the firmware arms its step ISR.
//
// Timer1 runs free at the CPU clock (normal mode). Each trial reads TCNT1, toggles Y DIR (PD6)
// as a mark, arms OCR1A `lead` ticks after the read and waits up to 3,000 ticks:
// - the compare ISR raises X STEP (PD2) as its first instruction; main lowers it again;
// - no compare by then: X DIR (PD5) toggles (a miss).
// Two orders of the arming, 64 trials for each lead, each order's leads in kLeads order, and Z
// DIR (PD7) toggled after each order:
// - order 0, "write then clear": OCR1A = t + lead, then TIFR1 = OCF1A (as the firmware's arm()
//   does, to drop a match of the previous OCR1A value);
// - order 1, "clear then write": TIFR1 = OCF1A, then OCR1A = t + lead.
// check_compare_lead.py reads the trace.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>

static const uint8_t kLeads[] = {8, 12, 16, 24, 48, 100, 200};
#define TRIALS 64

volatile uint8_t g_fired;

// Compare A: X STEP high at once (the first instruction), then the flag.
ISR(TIMER1_COMPA_vect, ISR_NAKED) {
  __asm__ __volatile__(
      "sbi %[port], %[bit]\n\t"
      "push r24\n\t"
      "ldi r24, 1\n\t"
      "sts g_fired, r24\n\t"
      "pop r24\n\t"
      "reti\n\t" ::[port] "I"(_SFR_IO_ADDR(PORTD)),
      [bit] "I"(PD2));
}

static void pause(uint16_t ticks) {
  const uint16_t s = TCNT1;
  while ((uint16_t)(TCNT1 - s) < ticks) {
  }
}

// One trial: arm `lead` ticks after the read of TCNT1 in the given order, wait for the compare.
static void trial(uint8_t lead, uint8_t clear_first) {
  cli();
  g_fired = 0;
  const uint16_t t = TCNT1;
  PIND = _BV(PD6);  // the mark: a fixed number of cycles after the read
  const uint16_t at = (uint16_t)(t + lead);
  if (clear_first) {
    TIFR1 = _BV(OCF1A);
    OCR1A = at;
  } else {
    OCR1A = at;
    TIFR1 = _BV(OCF1A);
  }
  sei();
  while (!g_fired && (uint16_t)(TCNT1 - t) < 3000) {
  }
  if (g_fired) {
    PORTD &= (uint8_t)~_BV(PD2);
  } else {
    PIND = _BV(PD5);
  }
  pause(500);
}

int main(void) {
  DDRD = _BV(PD2) | _BV(PD5) | _BV(PD6) | _BV(PD7);
  DDRB = _BV(PB0);  // ENABLE low: the drivers on
  TCCR1A = 0;
  TCCR1B = _BV(CS10);
  TIMSK1 = _BV(OCIE1A);
  sei();
  for (uint8_t order = 0; order < 2; ++order) {
    for (uint8_t k = 0; k < sizeof kLeads; ++k)
      for (uint8_t i = 0; i < TRIALS; ++i) trial(kLeads[k], order);
    PIND = _BV(PD7);
  }
  for (;;) {
  }
}

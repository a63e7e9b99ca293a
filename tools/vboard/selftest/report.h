// report.h: how the virtual board's probe programs report a finding: two bits on X DIR (PD5)
// and Y DIR (PD6), then a toggle of Z DIR (PD7) marking it; the trace records every DIR change
// (reports.py reads them back). DDRD must have the three pins as outputs.
#ifndef STEPCHOIR_VBOARD_SELFTEST_REPORT_H
#define STEPCHOIR_VBOARD_SELFTEST_REPORT_H

#include <avr/io.h>
#include <stdint.h>

static inline void report(uint8_t x, uint8_t y) {
  uint8_t d = PORTD & (uint8_t)~(_BV(PD5) | _BV(PD6));
  if (x) d |= _BV(PD5);
  if (y) d |= _BV(PD6);
  PORTD = d;
  PIND = _BV(PD7);
}

#endif  // STEPCHOIR_VBOARD_SELFTEST_REPORT_H

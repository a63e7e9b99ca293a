// pin_io.h: a board-table pin -> its AVR port registers (AVR build only).
#ifndef STEPCHOIR_PIN_IO_H
#define STEPCHOIR_PIN_IO_H

#include <avr/io.h>
#include <util/atomic.h>

#include "boards/pins.h"

namespace pio {

// PORTx register of a port letter; PINx and DDRx sit two and one bytes below it on every AVR.
inline volatile uint8_t *port_reg(char port) {
  switch (port) {
#ifdef PORTA
    case 'A': return &PORTA;
#endif
    case 'B': return &PORTB;
    case 'C': return &PORTC;
    case 'D': return &PORTD;
#ifdef PORTE
    case 'E': return &PORTE;
    case 'F': return &PORTF;
    case 'G': return &PORTG;
    case 'H': return &PORTH;
    case 'J': return &PORTJ;
    case 'K': return &PORTK;
    case 'L': return &PORTL;
#endif
    default: return 0;
  }
}
inline volatile uint8_t *pin_reg(char port) { return port_reg(port) - 2; }
inline volatile uint8_t *ddr_reg(char port) { return port_reg(port) - 1; }
inline uint8_t mask(board::Pin p) { return (uint8_t)(1u << p.bit); }

// Called from: main loop. Read-modify-write with interrupts off: the step ISRs write other
// bits of the same ports.
inline void write(board::Pin p, bool high) {
  if (!p.wired()) return;
  volatile uint8_t *r = port_reg(p.port);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (high) *r |= mask(p);
    else *r &= (uint8_t)~mask(p);
  }
}

// Called from: main loop. Makes p an output at level `high`.
inline void output(board::Pin p, bool high) {
  if (!p.wired()) return;
  write(p, high);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { *ddr_reg(p.port) |= mask(p); }
}

// Called from: main loop. Makes p an input, with the pull-up when `pullup`.
inline void input(board::Pin p, bool pullup) {
  if (!p.wired()) return;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { *ddr_reg(p.port) &= (uint8_t)~mask(p); }
  write(p, pullup);
}

// Called from: anywhere. Current level of an input.
inline bool read(board::Pin p) { return p.wired() && (*pin_reg(p.port) & mask(p)); }

}  // namespace pio

#endif  // STEPCHOIR_PIN_IO_H

// link.h: UART0 at 1,000,000 baud (U2X clear, UBRR0 = 0: exact at 16 MHz, sampled 16x),
// with interrupt-driven receive and transmit rings.
#ifndef STEPCHOIR_LINK_H
#define STEPCHOIR_LINK_H

#include <stdint.h>

namespace link {

// Called from: setup(). Configures UART0 and its interrupts.
void begin();

// Called from: main loop. Takes up to max received bytes into out; returns how many.
uint8_t read_some(uint8_t *out, uint8_t max);

// Called from: step ISR. The receive ring's head index: bytes the receive ISR took since an
// earlier call are (now - then) mod cfg::kRxRingBytes (fewer than a ring's worth between calls).
uint8_t rx_head();

}  // namespace link

#endif  // STEPCHOIR_LINK_H

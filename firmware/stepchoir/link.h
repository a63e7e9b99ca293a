// link.h: UART0 at 1,000,000 baud (U2X clear, UBRR0 = 0: exact at 16 MHz, sampled 16x),
// an interrupt-driven receive ring and a transmit ring the main loop feeds to the UART.
#ifndef STEPCHOIR_LINK_H
#define STEPCHOIR_LINK_H

#include <avr/io.h>
#include <stdint.h>

#include "config.h"

namespace link {

namespace detail {
// The receive ring (link.cpp): the receive ISR moves only the head, the main loop the tail.
extern volatile uint8_t g_rx[cfg::kRxRingBytes];
extern volatile uint8_t g_rx_head, g_rx_tail;
// The transmit ring: hal::send() moves the head, feed_tx() the tail (both the main loop).
extern volatile uint8_t g_tx[cfg::kTxRingBytes];
extern volatile uint8_t g_tx_head, g_tx_tail;
}  // namespace detail

// UCSR0B: receiver and transmitter on, with and without the receive interrupt (the
// transmitter has no interrupt: feed_tx).
const uint8_t kUartOn = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
const uint8_t kUartRxOff = _BV(RXEN0) | _BV(TXEN0);

// Called from: setup(). Configures UART0 and its interrupts.
void begin();

// Called from: main loop. Queues one encoded reply frame for the UART; drops it when the
// transmit ring is full.
void send_frame(const uint8_t *payload, uint8_t len);

// Called from: main loop. Bytes the receiver lost (hardware overrun, framing error or a full
// ring; saturates at 255), and its reset.
uint8_t rx_errors();
void reset_rx_errors();

// Called from: every ISR that may run long nested in the receive ISR (the motors' handlers),
// first thing, interrupts on. Turns the receive interrupt back on, which the receive ISR turns
// off while it runs: a byte that comes meanwhile enters at once (a receive ISR nested in
// another takes the bytes, and the outer one finds none left). 3 cycles.
__attribute__((always_inline)) inline void rx_resume() { UCSR0B = kUartOn; }

// Called from: main loop (wait_byte's loop, after each byte the main loop takes, and send()).
// Hands the UART the next byte of the transmit ring when its data register is empty. The
// transmitter has no ISR: at 1,000,000 baud one took 70-85 cycles of every 160 while a reply
// went out, on top of the receive ISR's 55 then, and held up the motors' handlers. Fed once a
// received byte (or a wait loop's pass), a reply still goes out at the line's full speed.
__attribute__((always_inline)) inline void feed_tx() {
  const uint8_t tail = detail::g_tx_tail;
  if (tail != detail::g_tx_head && (UCSR0A & _BV(UDRE0))) {
    UDR0 = detail::g_tx[tail];
    detail::g_tx_tail = (uint8_t)((tail + 1) & (cfg::kTxRingBytes - 1));
  }
}

// Passes of wait_byte's loop (20 cycles each with nothing to send, by the disassembly; longer
// when ISRs nest) that make about `ticks`.
constexpr uint16_t wait_passes(uint16_t ticks) { return (uint16_t)(ticks / 20u); }

// Called from: main loop, while a frame is coming in. Takes the next received byte into out,
// waiting for it at most max_passes passes of its loop (wait_passes); false when none came.
// Inlined: the main loop takes a frame's bytes one by one as they come, in the 85 or so of
// every 160 cycles the receive ISR leaves it (called, this took 40 cycles a byte and the loop
// fell behind the line). The wait is counted in passes, not read from Timer1: a 16-bit timer read
// with interrupts on could take a nested ISR's high byte.
__attribute__((always_inline)) inline bool wait_byte(uint8_t *out, uint16_t max_passes) {
  const uint8_t tail = detail::g_rx_tail;
  for (uint16_t passes = max_passes; detail::g_rx_head == tail;) {
    feed_tx();
    if (passes-- == 0) return false;
  }
  *out = detail::g_rx[tail];
  detail::g_rx_tail = (uint8_t)((tail + 1) & (cfg::kRxRingBytes - 1));
  return true;
}

}  // namespace link

#endif  // STEPCHOIR_LINK_H

// link.h: UART0 at 1,000,000 baud (U2X clear, UBRR0 = 0: exact at 16 MHz, sampled 16x),
// with interrupt-driven receive and transmit rings.
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
}  // namespace detail

// Called from: setup(). Configures UART0 and its interrupts.
void begin();

// Passes of wait_byte's loop (7 cycles each, longer when ISRs nest) that make about `ticks`.
constexpr uint16_t wait_passes(uint16_t ticks) { return (uint16_t)(ticks / 7u); }

// Called from: main loop, while a frame is coming in. Takes the next received byte into out,
// waiting for it at most max_passes passes of its loop (wait_passes); false when none came.
// Inlined: the main loop takes a frame's bytes one by one as they come, in the 107 of every
// 160 cycles the receive ISR leaves it (called, this took 40 cycles a byte and the loop fell
// behind the line). The wait is counted in passes, not read from Timer1: a 16-bit timer read
// with interrupts on could take a nested ISR's high byte.
__attribute__((always_inline)) inline bool wait_byte(uint8_t *out, uint16_t max_passes) {
  const uint8_t tail = detail::g_rx_tail;
  for (uint16_t passes = max_passes; detail::g_rx_head == tail;) {
    if (passes-- == 0) return false;
  }
  *out = detail::g_rx[tail];
  detail::g_rx_tail = (uint8_t)((tail + 1) & (cfg::kRxRingBytes - 1));
  return true;
}

// Called from: step ISR. The receive ring's head index: bytes the receive ISR took since an
// earlier call are (now - then) mod cfg::kRxRingBytes (fewer than a ring's worth between calls).
uint8_t rx_head();

// Called from: step ISR. True when the receive ring is full: bytes that come now are dropped
// (and counted, up to 255), so the head stands still although the receive ISR runs for each.
// Traced at full line speed on the Mega: the step ISR saw an unmoved head, took the quiet
// line's bookkeeping margin, and the bookkeeping, stretched by the receive ISRs, made the
// next edge late.
__attribute__((always_inline)) inline bool rx_full() {
  return (uint8_t)((detail::g_rx_head + 1) & (cfg::kRxRingBytes - 1)) == detail::g_rx_tail;
}

// Called from: step ISR, interrupts on, right after its entry (before the sei, this added 9
// cycles to its longest interrupts-off stretch). Holds the transmit ISR off while the step ISR
// runs; returns whether it was on, for release_tx. A reply then goes out between step ISR
// invocations only, up to an invocation later (the longest in the pitch benchmark: 1.2 ms
// with light traffic, 1.6 ms at full line speed):
// with a reply going out and frames coming in at full line speed, the two UART ISRs took 61 %
// of the CPU in the step ISR's way from one edge to the next (traced), and edges came 30-50 us
// late. Receiving cannot wait (the UART holds two bytes); a reply can. A transmit ISR between
// the read and the write is harmless: if it emptied the ring and turned itself off,
// release_tx turns it on once more and it turns itself off again.
__attribute__((always_inline)) inline uint8_t hold_tx() {
  const uint8_t on = UCSR0B & _BV(UDRIE0);
  UCSR0B = (uint8_t)(UCSR0B & ~_BV(UDRIE0));
  return on;
}

// Called from: step ISR, interrupts on, before its last cli (after it, this lengthened its
// longest interrupts-off stretch). Lets the transmit ISR run again if hold_tx found it on (the
// main loop, which alone queues replies, has not run meanwhile); if the step ISR goes on
// after all, it holds it off again.
__attribute__((always_inline)) inline void release_tx(uint8_t on) { UCSR0B = (uint8_t)(UCSR0B | on); }

}  // namespace link

#endif  // STEPCHOIR_LINK_H

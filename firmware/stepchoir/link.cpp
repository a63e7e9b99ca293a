// link.cpp: UART0 driver: receive ISR -> ring -> main loop; main loop -> ring -> UART (fed by
// the main loop, link::feed_tx()).
#include "link.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "config.h"
#include "src/stepchoir_protocol.h"

#if defined(USART0_RX_vect)
#define SC_UART_RX_VECT USART0_RX_vect
#else
#define SC_UART_RX_VECT USART_RX_vect
#endif

using link::detail::g_rx;
using link::detail::g_rx_head;
using link::detail::g_rx_tail;

namespace link {
namespace detail {
volatile uint8_t g_rx[cfg::kRxRingBytes];
volatile uint8_t g_rx_head, g_rx_tail;
volatile uint8_t g_tx[cfg::kTxRingBytes];
volatile uint8_t g_tx_head, g_tx_tail;
}  // namespace detail
}  // namespace link

namespace {
using link::detail::g_tx;
using link::detail::g_tx_head;
using link::detail::g_tx_tail;
volatile uint8_t g_rx_errors;  // bytes lost: hardware overrun, framing error or full ring (saturates)
const uint8_t kRxMask = cfg::kRxRingBytes - 1;
const uint8_t kTxMask = cfg::kTxRingBytes - 1;
}  // namespace

// UART receive ISR. Who: a byte arrived (every 10 us at most). Assembly. Interrupts are off
// for four short stretches, so that a STEP edge due meanwhile waits little (by the instruction
// count on the Uno, entry included; a cycle more on the Mega, whose entry and reti take one
// more):
//   - 14 cycles at entry: it turns its own interrupt off (kUartRxOff) and interrupts back on.
//     The interrupts that nest from there may be long (a motor's handler): each handler turns
//     the receive interrupt back on first (rx_resume), and a receive ISR nested in one takes
//     the byte (this one then finds none).
//   - 15 cycles a byte: with RXC0 set it reads the status and the byte and reserves the byte's
//     slot in the ring (the ring's order is the bytes' order even when a later byte's ISR
//     nests in this one; the main loop, the only reader, runs only when no ISR does); then,
//     interrupts on, it stores the byte, or a frame delimiter for a byte the UART flagged (a
//     framing error, or bytes lost before it: the frame it was in fails and the decoder
//     resyncs), and counts the loss (interrupts off for those 8 cycles: a nested receive ISR
//     counts too). A ring the main loop let fill up laps: its bytes are lost, counted once. It
//     takes every byte the UART holds before it leaves.
//   - At exit: 8 cycles for the last check (RXC0 clear) up to sei, then 7 from the SREG
//     restore to reti. (The receive interrupt is turned back on in between, interrupts on: a
//     byte come since enters at once, on a real chip and on the virtual board, which makes the
//     interrupt pending when RXCIE0 is written on with RXC0 set: vboard_uart_rxcie.)
// About 75 cycles for a lone byte, entry included; 31 for each further one it finds waiting.
// Why it is split so: docs/decisions/011-split-receive-isr.md.
ISR(SC_UART_RX_VECT, ISR_NAKED) {
  __asm__ __volatile__(
      "push r24\n\t"
      "ldi r24, %[off]\n\t"
      "sts %[ucsrb], r24\n\t"
      "sei\n\t"
      "in r24, __SREG__\n\t"  // the interrupted code's flags (no instruction since changed them)
      "push r24\n\t"
      "push r30\n\t"
      "push r31\n\t"
      "1:\n\t"
      "cli\n\t"
      "lds r31, %[ucsra]\n\t"
      "sbrs r31, %[rxc]\n\t"
      "rjmp 9f\n\t"
      "lds r24, %[udr]\n\t"
      "lds r30, %[head]\n\t"
      "inc r30\n\t"
      "andi r30, %[mask]\n\t"
      "sts %[head], r30\n\t"
      "sei\n\t"
      "andi r31, %[errbits]\n\t"
      "breq 2f\n\t"
      "clr r24\n\t"  // a flagged byte: a delimiter in its place
      "rjmp 3f\n\t"
      "2:\n\t"
      "lds r31, %[tail]\n\t"
      "cp r30, r31\n\t"
      "brne 4f\n\t"
      "3:\n\t"
      "cli\n\t"  // a loss (rare): counted with interrupts off, a nested receive ISR may count too
      "lds r31, %[errors]\n\t"
      "inc r31\n\t"
      "breq 5f\n\t"
      "sts %[errors], r31\n\t"
      "5:\n\t"
      "sei\n\t"
      "4:\n\t"
      "dec r30\n\t"
      "andi r30, %[mask]\n\t"
      "ldi r31, 0\n\t"
      "subi r30, lo8(-(%[buf]))\n\t"
      "sbci r31, hi8(-(%[buf]))\n\t"
      "st Z, r24\n\t"
      "rjmp 1b\n\t"
      "9:\n\t"
      "sei\n\t"
      "ldi r24, %[on]\n\t"
      "sts %[ucsrb], r24\n\t"
      "pop r31\n\t"
      "pop r30\n\t"
      "pop r24\n\t"
      "andi r24, 0x7F\n\t"  // restored with I clear: reti sets it
      "out __SREG__, r24\n\t"
      "pop r24\n\t"
      "reti\n\t" ::[ucsra] "i"(_SFR_MEM_ADDR(UCSR0A)),
      [ucsrb] "i"(_SFR_MEM_ADDR(UCSR0B)), [off] "i"(link::kUartRxOff), [on] "i"(link::kUartOn),
      [rxc] "I"(RXC0), [udr] "i"(_SFR_MEM_ADDR(UDR0)), [errbits] "M"(_BV(DOR0) | _BV(FE0)),
      [head] "i"(&g_rx_head), [tail] "i"(&g_rx_tail), [buf] "i"(g_rx), [mask] "M"(kRxMask),
      [errors] "i"(&g_rx_errors));
}

namespace link {

void begin() {
  UBRR0 = 0;                 // 16 MHz / (16 * (0 + 1)) = 1,000,000 baud exactly
  UCSR0A = 0;                // U2X0 clear: 16x sampling (and simavr times bytes right)
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8 data bits, no parity, 1 stop bit
  UCSR0B = kUartOn;
  // A delimiter first: the host's decoder starts between frames whatever came before (a
  // bootloader's bytes). The transmitter is then fed by polling UDRE0 (feed_tx), which the
  // virtual board (simavr 1.6) first sets once a byte has been written: after a reset it reads
  // clear there.
  UDR0 = sc::kDelimiter;
}

void send_frame(const uint8_t *payload, uint8_t len) {
  uint8_t frame[sc::kMaxFrameWire];
  const uint8_t n = sc::encode_frame(payload, len, frame);
  const uint8_t used = (uint8_t)((g_tx_head - g_tx_tail) & kTxMask);
  if (n == 0 || (uint16_t)used + n >= cfg::kTxRingBytes) return;
  for (uint8_t i = 0; i < n; ++i) {
    g_tx[g_tx_head] = frame[i];
    g_tx_head = (uint8_t)((g_tx_head + 1) & kTxMask);
  }
  feed_tx();
}

uint8_t rx_errors() { return g_rx_errors; }

void reset_rx_errors() { g_rx_errors = 0; }

}  // namespace link

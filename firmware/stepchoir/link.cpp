// link.cpp: UART0 driver: receive ISR -> ring -> main loop; main loop -> ring -> UDRE ISR.
#include "link.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "config.h"
#include "hal.h"

#if defined(USART0_RX_vect)
#define SC_UART_RX_VECT USART0_RX_vect
#define SC_UART_UDRE_VECT USART0_UDRE_vect
#else
#define SC_UART_RX_VECT USART_RX_vect
#define SC_UART_UDRE_VECT USART_UDRE_vect
#endif

// Entry and exit of the two assembly ISRs below: they use r24, r25, r30, r31 and the flags.
#define SC_ISR_SAVE "push r24\n\tin r24, __SREG__\n\tpush r24\n\tpush r25\n\tpush r30\n\tpush r31\n\t"
#define SC_ISR_RESTORE "pop r31\n\tpop r30\n\tpop r25\n\tpop r24\n\tout __SREG__, r24\n\tpop r24\n\treti\n\t"

using link::detail::g_rx;
using link::detail::g_rx_head;
using link::detail::g_rx_tail;

namespace link {
namespace detail {
volatile uint8_t g_rx[cfg::kRxRingBytes];
volatile uint8_t g_rx_head, g_rx_tail;
}  // namespace detail
}  // namespace link

namespace {
volatile uint8_t g_tx[cfg::kTxRingBytes];
volatile uint8_t g_tx_head, g_tx_tail;
volatile uint8_t g_rx_errors;  // bytes lost: hardware overrun, framing error or full ring (saturates)
const uint8_t kRxMask = cfg::kRxRingBytes - 1;
const uint8_t kTxMask = cfg::kTxRingBytes - 1;
}  // namespace

// UART receive ISR. Who: a byte arrived (every 10 us at most). Written in assembly because it
// runs up to 100,000 times a second and nests inside the step ISR's waits: the virtual board
// measures at most 53 cycles (Uno) / 54 (Mega), interrupt entry to RETI, about 49 on average
// (build/e2e/*.csv, "isr=" summary lines). Stores the byte in the
// ring, or counts it lost (saturating) when the ring is full or the UART flagged an error.
ISR(SC_UART_RX_VECT, ISR_NAKED) {
  __asm__ __volatile__(
      SC_ISR_SAVE
      "lds r25, %[ucsra]\n\t"
      "lds r24, %[udr]\n\t"
      "andi r25, %[errbits]\n\t"
      "brne 2f\n\t"
      "lds r30, %[head]\n\t"
      "mov r25, r30\n\t"
      "inc r25\n\t"
      "andi r25, %[mask]\n\t"
      "lds r31, %[tail]\n\t"
      "cp r25, r31\n\t"
      "breq 2f\n\t"
      "ldi r31, 0\n\t"
      "subi r30, lo8(-(%[buf]))\n\t"
      "sbci r31, hi8(-(%[buf]))\n\t"
      "st Z, r24\n\t"
      "sts %[head], r25\n\t"
      "rjmp 3f\n\t"
      "2:\n\t"
      "lds r24, %[errors]\n\t"
      "inc r24\n\t"
      "breq 3f\n\t"
      "sts %[errors], r24\n\t"
      "3:\n\t"
      SC_ISR_RESTORE ::[ucsra] "i"(_SFR_MEM_ADDR(UCSR0A)),
      [udr] "i"(_SFR_MEM_ADDR(UDR0)), [errbits] "M"(_BV(DOR0) | _BV(FE0)), [head] "i"(&g_rx_head),
      [tail] "i"(&g_rx_tail), [buf] "i"(g_rx), [mask] "M"(kRxMask), [errors] "i"(&g_rx_errors));
}

// UART data-register-empty ISR. Who: the transmitter wants a byte (every 10 us while a reply
// goes out). In assembly for the same reason as the receive ISR: measured at most 60 cycles, about
// 46 on average.
ISR(SC_UART_UDRE_VECT, ISR_NAKED) {
  __asm__ __volatile__(
      SC_ISR_SAVE
      "lds r30, %[tail]\n\t"
      "lds r25, %[head]\n\t"
      "cp r30, r25\n\t"
      "breq 1f\n\t"
      "mov r25, r30\n\t"
      "ldi r31, 0\n\t"
      "subi r30, lo8(-(%[buf]))\n\t"
      "sbci r31, hi8(-(%[buf]))\n\t"
      "ld r24, Z\n\t"
      "sts %[udr], r24\n\t"
      "inc r25\n\t"
      "andi r25, %[mask]\n\t"
      "sts %[tail], r25\n\t"
      "rjmp 2f\n\t"
      "1:\n\t"
      "lds r24, %[ucsrb]\n\t"
      "andi r24, %[noudrie]\n\t"
      "sts %[ucsrb], r24\n\t"
      "2:\n\t"
      SC_ISR_RESTORE ::[tail] "i"(&g_tx_tail),
      [head] "i"(&g_tx_head), [buf] "i"(g_tx), [udr] "i"(_SFR_MEM_ADDR(UDR0)), [mask] "M"(kTxMask),
      [ucsrb] "i"(_SFR_MEM_ADDR(UCSR0B)), [noudrie] "M"(0xFF & ~_BV(UDRIE0)));
}

namespace link {

void begin() {
  UBRR0 = 0;                 // 16 MHz / (16 * (0 + 1)) = 1,000,000 baud exactly
  UCSR0A = 0;                // U2X0 clear: 16x sampling (and simavr times bytes right)
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8 data bits, no parity, 1 stop bit
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

uint8_t rx_head() { return g_rx_head; }

}  // namespace link

namespace hal {

void send(const uint8_t *payload, uint8_t len) {
  uint8_t frame[sc::kMaxFrameWire];
  const uint8_t n = sc::encode_frame(payload, len, frame);
  const uint8_t used = (uint8_t)((g_tx_head - g_tx_tail) & kTxMask);
  if (n == 0 || (uint16_t)used + n >= cfg::kTxRingBytes) return;
  for (uint8_t i = 0; i < n; ++i) {
    g_tx[g_tx_head] = frame[i];
    g_tx_head = (uint8_t)((g_tx_head + 1) & kTxMask);
  }
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { UCSR0B |= _BV(UDRIE0); }
}

uint16_t uart_overruns() { return g_rx_errors; }

void reset_uart_overruns() { g_rx_errors = 0; }

}  // namespace hal

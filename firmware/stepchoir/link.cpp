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

namespace {
volatile uint8_t g_rx[cfg::kRxRingBytes];
volatile uint8_t g_rx_head, g_rx_tail;
volatile uint8_t g_tx[cfg::kTxRingBytes];
volatile uint8_t g_tx_head, g_tx_tail;
volatile uint16_t g_overruns;
const uint8_t kRxMask = cfg::kRxRingBytes - 1;
const uint8_t kTxMask = cfg::kTxRingBytes - 1;
}  // namespace

// UART receive ISR. Who: a byte arrived (every 10 us at most). Budget: about 40 cycles.
ISR(SC_UART_RX_VECT) {
  const uint8_t status = UCSR0A;
  const uint8_t b = UDR0;
  if (status & (_BV(DOR0) | _BV(FE0))) g_overruns = (uint16_t)(g_overruns + 1);
  const uint8_t next = (uint8_t)((g_rx_head + 1) & kRxMask);
  if (next == g_rx_tail) {
    g_overruns = (uint16_t)(g_overruns + 1);
    return;
  }
  g_rx[g_rx_head] = b;
  g_rx_head = next;
}

// UART data-register-empty ISR. Who: the transmitter wants a byte. Budget: about 35 cycles.
ISR(SC_UART_UDRE_VECT) {
  if (g_tx_head == g_tx_tail) {
    UCSR0B &= (uint8_t)~_BV(UDRIE0);
    return;
  }
  UDR0 = g_tx[g_tx_tail];
  g_tx_tail = (uint8_t)((g_tx_tail + 1) & kTxMask);
}

namespace link {

void begin() {
  UBRR0 = 0;                 // 16 MHz / (16 * (0 + 1)) = 1,000,000 baud exactly
  UCSR0A = 0;                // U2X0 clear: 16x sampling (and simavr times bytes right)
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8 data bits, no parity, 1 stop bit
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

bool read(uint8_t *byte) {
  if (g_rx_head == g_rx_tail) return false;
  *byte = g_rx[g_rx_tail];
  g_rx_tail = (uint8_t)((g_rx_tail + 1) & kRxMask);
  return true;
}

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

uint16_t uart_overruns() {
  uint16_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = g_overruns; }
  return n;
}

void reset_uart_overruns() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { g_overruns = 0; }
}

}  // namespace hal

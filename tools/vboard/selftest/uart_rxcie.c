// uart_rxcie.c: tiny ATmega328P program measuring how soon the virtual board takes the UART's
// receive interrupt when RXCIE0 is turned on while a byte waits (RXC0 set). On the chip the
// interrupt is the level RXC0 AND RXCIE0, taken at once (the instruction after the write, then
// the 4-cycle response). simavr 1.6 alone marks it pending only when it raises RXC0 (a byte
// arriving, and again every byte time while its buffer holds one), so it came up to a byte time
// (160 cycles at 1,000,000 baud) late; the virtual board makes it pending at the write.
//
// For each byte the client sends (uart_rxcie_client.py): wait for RXC0 with the interrupt off,
// let 1,000 cycles pass, turn RXCIE0 on and count Timer1 cycles until the ISR has read TCNT1.
// Each finding is a report: X DIR (PD5) = the ISR came within kPromptCycles, Y DIR (PD6) = it
// came at all (within 2 ms), then Z DIR (PD7) toggled. check_uart_rxcie.py reads the trace.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>

#include "report.h"

// From the write's cycle to the ISR's TCNT1 read: the write's second cycle, one instruction,
// the 4-cycle response, the vector's jmp and the ISR's prologue; about 30 on the chip.
#define kPromptCycles 60

volatile uint16_t g_seen;
volatile uint8_t g_ran;

ISR(USART_RX_vect) {
  g_seen = TCNT1;
  g_ran = 1;
  UCSR0B = _BV(RXEN0) | _BV(TXEN0);  // off again
  (void)UDR0;
}

int main(void) {
  DDRD = _BV(PD5) | _BV(PD6) | _BV(PD7);
  TCCR1A = 0;
  TCCR1B = _BV(CS10);  // CPU cycles
  UBRR0 = 0;           // 1,000,000 baud, U2X clear
  UCSR0A = 0;
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0);
  sei();
  for (;;) {
    while (!(UCSR0A & _BV(RXC0))) {
    }
    const uint16_t waited = TCNT1;
    while ((uint16_t)(TCNT1 - waited) < 1000) {
    }
    g_ran = 0;
    cli();
    const uint16_t on = TCNT1;
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
    sei();
    while (!g_ran && (uint16_t)(TCNT1 - on) < 32000) {
    }
    report(g_ran && (uint16_t)(g_seen - on) < kPromptCycles, g_ran);
    if (!g_ran) {
      UCSR0B = _BV(RXEN0) | _BV(TXEN0);
      (void)UDR0;
    }
  }
}

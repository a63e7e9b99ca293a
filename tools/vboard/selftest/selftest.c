// selftest.c: tiny ATmega328P program exercising the virtual board: UART echo, step pulses, switch mirror.
//
// Everything runs in interrupts; the main loop only sleeps (idle), so Timer1 interrupts are taken
// with a fixed latency and the step spacing is exact to the cycle while the UART is quiet.
// - Timer1 CTC, OCR1A = 1599, no prescaler: one X STEP (PD2) pulse every 1600 cycles with X DIR
//   (PD5) high and ENABLE (PB0) low. The pulse is raised with SBI and dropped by writing PIND.
//   The same interrupt mirrors the X end switch input (PB1, pull-up) onto Y DIR (PD6) and
//   rewrites PORTB, which must not disturb the switch level the board drives.
// - UART0 at 1,000,000 baud (UBRR0 = 0, U2X0 clear): each received byte b is answered with b+1
//   twice, waiting for UDRE0 in between, so transmission is the bottleneck and the receive
//   FIFO backs up. Z DIR (PD7) toggles after each UDR0 write, so the trace shows the spacing.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#define SWITCH_PULLUPS (_BV(PB1) | _BV(PB2) | _BV(PB3))

// Timer1 compare match A: one STEP pulse, then the switch mirror.
ISR(TIMER1_COMPA_vect) {
  PORTD |= _BV(PD2);
  __asm__ __volatile__("nop\n\tnop\n\tnop\n\tnop\n\t");
  PIND = _BV(PD2);  // toggle back low
  if (PINB & _BV(PB1))
    PORTD |= _BV(PD6);
  else
    PORTD &= ~_BV(PD6);
  PORTB = SWITCH_PULLUPS;
}

// Sends one byte once the transmit buffer is free, then marks it on Z DIR.
static void uart_send(uint8_t byte) {
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = byte;
  PIND = _BV(PD7);
}

// UART0 received a byte: answer it twice, +1.
ISR(USART_RX_vect) {
  const uint8_t reply = (uint8_t)(UDR0 + 1);
  uart_send(reply);
  uart_send(reply);
}

// Sets up pins, UART and Timer1, then sleeps forever.
int main(void) {
  DDRD = _BV(PD2) | _BV(PD5) | _BV(PD6) | _BV(PD7);
  PORTD = _BV(PD5);
  DDRB = _BV(PB0);
  PORTB = SWITCH_PULLUPS;  // ENABLE low, pull-ups on the switch inputs

  UBRR0H = 0;
  UBRR0L = 0;
  UCSR0A = 0;
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0);

  OCR1A = 1599;
  TCCR1A = 0;
  TCCR1B = _BV(WGM12) | _BV(CS10);
  TIMSK1 = _BV(OCIE1A);
  set_sleep_mode(SLEEP_MODE_IDLE);
  sleep_enable();
  sei();
  for (;;) sleep_cpu();
}

// avr_uart.cpp: the UART0 bridge between the pty and simavr: byte timing, receive feed, transmit double buffer.
#include "avr_adapter.h"
#include "avr_uart_timing.h"

#include <algorithm>
#include <cstdint>

extern "C" {
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
#include <simavr/sim_regbit.h>
}

namespace vboard {

// The AVR wrote the register holding RXCIE0 (UCSR0B). On a real chip the receive interrupt is
// the level RXC0 AND RXCIE0: turned on while a byte waits, it is taken at once. simavr 1.6 marks
// the interrupt pending only when it raises RXC0 (when a byte comes in, and again every byte time
// while its buffer holds one), so a byte waiting when RXCIE0 comes on would wait up to a byte
// time more. Here it is made pending at once, as on the chip (`ctest -R vboard_uart_rxcie`).
void AvrAdapter::on_rxcie_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  (void)addr;
  (void)v;
  avr_uart_t *uart = static_cast<avr_uart_t *>(static_cast<AvrAdapter *>(param)->uart_);
  if (avr_regbit_get(avr, uart->rxc.enable) && avr_regbit_get(avr, uart->rxc.raised) && !uart->rxc.pending)
    avr_raise_interrupt(avr, &uart->rxc);
}

// The cycle the next host byte reaches UART0 at: `earliest`, or later when the bridge releases
// it later (a duplicated byte's second copy is already here).
uint64_t AvrAdapter::rx_cycle(uint64_t earliest) const {
  if (repeat_byte_ >= 0) return earliest;
  const uint64_t release_ns = link_.rx_next_ns();
  if (release_ns == UINT64_MAX) return 0;
  if (release_ns <= host_ns(earliest)) return earliest;
  if (!pacer_) return 0;  // the loop kicks again after the next chunk
  return pacer_->cycle_at_sim_ns(release_ns);
}

// Starts feeding received host bytes to UART0: each on the cycle its bridge releases it, one
// per byte time (or the bridge's pace) at most.
void AvrAdapter::kick_rx() {
  if (rx_timer_armed_ || xoff_) return;
  const uint64_t now = avr_->cycle;
  const uint64_t at = rx_cycle(next_rx_cycle_ > now ? next_rx_cycle_ : now + 1);
  if (at == 0) return;
  avr_cycle_timer_register(avr_, at - now, &AvrAdapter::on_rx_timer, this);
  rx_timer_armed_ = true;
}

// Lowers the current run's end to the cycle the bridge next passes board bytes to the host.
void AvrAdapter::end_run_at_tx_pass() {
  const uint64_t pass_ns = link_.tx_next_ns();
  if (pass_ns == UINT64_MAX || !pacer_) return;
  const uint64_t now = avr_->cycle;
  const uint64_t at = pass_ns > pacer_->sim_ns(now) ? pacer_->cycle_at_sim_ns(pass_ns) : now + 1;
  if (at < run_end_cycle_) run_end_cycle_ = at;
}

// UART0 byte time in cycles, from its registers (avr_uart_timing.h).
uint64_t AvrAdapter::uart_byte_cycles() const {
  return vboard::uart_byte_cycles(avr_, static_cast<const avr_uart_t *>(uart_));
}

// simavr 1.6 computes the byte time only when UBRRnL is written (never if the firmware keeps the
// reset value 0) and always counts a parity bit: set it from the registers before each byte.
void AvrAdapter::fix_uart_timing() {
  static_cast<avr_uart_t *>(uart_)->cycles_per_byte = uart_byte_cycles();
}

// The AVR wrote UDR0: fix the byte time before simavr starts its TX timer, queue the byte, and
// model the transmit double buffer simavr lacks (it raises UDRE only when a byte has been sent):
// a byte written while the shift register is idle moves on at once and UDR0 is free again; one
// written while it is busy waits in UDR0 until the shift register takes it.
void AvrAdapter::on_uart_output(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  avr_t *avr = self->avr_;
  self->fix_uart_timing();
  ++self->uart_out_bytes_;
  self->link_.tx_push(static_cast<uint8_t>(value), self->host_ns(avr->cycle));
  self->end_run_at_tx_pass();
  const uint64_t byte_cycles = self->uart_byte_cycles();
  if (self->tx_shift_free_cycle_ <= avr->cycle) {
    self->tx_shift_free_cycle_ = avr->cycle + byte_cycles;
    avr_raise_interrupt(avr, &static_cast<avr_uart_t *>(self->uart_)->udrc);
  } else {
    const uint64_t moves_cycle = self->tx_shift_free_cycle_;
    self->tx_shift_free_cycle_ += byte_cycles;
    // one cycle after simavr's own TX timer for the byte ahead, which would clear UDRE again
    avr_cycle_timer_register(avr, moves_cycle + 1 - avr->cycle, &AvrAdapter::on_udr_free_timer, self);
  }
}

// The byte waiting in UDR0 moved into the shift register: UDR0 is free (UDRE) again.
uint64_t AvrAdapter::on_udr_free_timer(avr_t *avr, uint64_t when, void *param) {
  (void)when;
  avr_uart_t *uart = static_cast<avr_uart_t *>(static_cast<AvrAdapter *>(param)->uart_);
  if (avr_regbit_get(avr, uart->txen)) avr_raise_interrupt(avr, &uart->udrc);
  return 0;
}

// simavr's receive FIFO has room again.
void AvrAdapter::on_uart_xon(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  self->xoff_ = false;
  self->kick_rx();
}

// simavr's receive FIFO is full (value 1) or not (0).
void AvrAdapter::on_uart_xoff(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  if (value != 0 && !self->xoff_) ++self->uart_xoff_count_;
  self->xoff_ = value != 0;
  if (!self->xoff_) self->kick_rx();
}

// Delivers one host byte to UART0; reschedules itself one byte time (or the bridge's pace,
// set_rx_gap_cycles, when longer) later while bytes remain, or for the cycle the bridge
// releases the next one.
uint64_t AvrAdapter::on_rx_timer(avr_t *avr, uint64_t when, void *param) {
  (void)when;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  const uint64_t at = self->xoff_ ? 0 : self->rx_cycle(avr->cycle);
  if (at == 0) {
    self->rx_timer_armed_ = false;  // XON (or the next poll) restarts it
    return 0;
  }
  if (at > avr->cycle) return at;  // not released yet: stays armed
  const avr_uart_t *uart = static_cast<const avr_uart_t *>(self->uart_);
  uint8_t byte;
  bool deliver = true;
  if (self->repeat_byte_ >= 0) {  // the second copy of a duplicated byte
    byte = static_cast<uint8_t>(self->repeat_byte_);
    self->repeat_byte_ = -1;
  } else {
    byte = self->link_.rx_pop();
    if (self->noise_) {
      const LineOutcome o = self->noise_->pass(byte);
      byte = o.byte;
      deliver = o.count > 0;  // a lost byte still takes its time on the line
      if (o.count == 2) self->repeat_byte_ = byte;
    }
  }
  if (deliver && avr_regbit_get(avr, uart->rxen)) {
    const unsigned unread_bytes =
        static_cast<unsigned>(uart->input.write - uart->input.read) & (uart_fifo_fifo_size - 1);
    if (unread_bytes >= 3) ++self->uart_would_overrun_;
    self->fix_uart_timing();
    avr_raise_irq(self->uart_input_irq_, byte);
    ++self->uart_in_bytes_;
    if (!self->in_frame_) self->frame_first_cycle_ = avr->cycle;
    self->in_frame_ = byte != 0;
    if (byte == 0 && self->frame_trace_) self->frame_trace_->frame_end(avr->cycle, avr->cycle - self->frame_first_cycle_);
  } else if (deliver) {
    ++self->uart_in_lost_;  // receiver off: the byte is lost, as on the real chip
    if (self->in_bootloader_ && self->boot_quiet_cycles_)
      self->boot_end_cycle_ = std::max(self->boot_end_cycle_, avr->cycle + self->boot_quiet_cycles_);
  }
  self->next_rx_cycle_ = avr->cycle + std::max(self->uart_byte_cycles(), self->rx_gap_cycles_);
  if (self->xoff_ || (self->repeat_byte_ < 0 && self->link_.rx_next_ns() == UINT64_MAX)) {
    self->rx_timer_armed_ = false;
    return 0;
  }
  return self->next_rx_cycle_;  // a byte the bridge releases later waits there (rx_cycle)
}

}  // namespace vboard

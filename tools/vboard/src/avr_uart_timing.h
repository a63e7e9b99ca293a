// avr_uart_timing.h: a simavr UART's byte time from its registers, as the chip times it: simavr
// 1.6 computes its own only when UBRRnL is written, ignores U2Xn and always counts a parity bit.
// Called from: the virtual board's UART0 bridge (avr_uart.cpp) and the 16U2 bench
// (tools/bench/chip_16u2.cpp), before each byte they send or take.
#ifndef STEPCHOIR_VBOARD_AVR_UART_TIMING_H
#define STEPCHOIR_VBOARD_AVR_UART_TIMING_H

#include <cstdint>

extern "C" {
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
}

namespace vboard {

// Cycles of one frame: (UBRR+1) * (U2X ? 8 : 16) per bit; start, data, parity and stop bits.
inline uint64_t uart_byte_cycles(const avr_t *avr, const avr_uart_t *uart) {
  const uint8_t *data = avr->data;
  const uint32_t ubrr = data[uart->ubrrl.reg] | ((data[uart->ubrrh.reg] & 0x0f) << 8);
  const bool u2x = (data[uart->u2x.reg] >> uart->u2x.bit) & 1;
  static const int kDataBits[8] = {5, 6, 7, 8, 8, 8, 8, 9};
  const int ucsz = ((data[uart->ucsz.reg] >> uart->ucsz.bit) & 3) |
                   (((data[uart->ucsz2.reg] >> uart->ucsz2.bit) & 1) << 2);
  const int stop_bits = 1 + ((data[uart->usbs.reg] >> uart->usbs.bit) & 1);
  const int parity_bits = ((data[uart->r_ucsrc] >> 4) & 3) != 0 ? 1 : 0;  // UPMn1:0
  const uint64_t bit_cycles = static_cast<uint64_t>(ubrr + 1) * (u2x ? 8 : 16);
  return bit_cycles * static_cast<uint64_t>(1 + kDataBits[ucsz] + parity_bits + stop_bits);
}

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_AVR_UART_TIMING_H

// chip_16u2.h: an Uno or Mega R3's USB bridge as a simulated chip: Arduino's usbserial firmware
// (a hex the user gives: Debian ships its source only) on simavr's AT90USB162, the ATmega16U2's
// predecessor with the same core, USB controller, USART1 and Timer0. The host side is driven as
// the host's USB stack drives it: a bus reset, the control requests that enumerate it and open
// the port (address, configuration, line coding, DTR), bulk OUT packets to endpoint 4, bulk IN
// polls of endpoint 3. USART1 faces the board: every byte the firmware hands it is logged with
// its cycle, and bytes from the board are fed in at the line's rate.
// Called from: bridge_16u2_bench.cpp (one thread; simavr is not thread-safe).
#ifndef STEPCHOIR_BENCH_CHIP_16U2_H
#define STEPCHOIR_BENCH_CHIP_16U2_H

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

struct avr_t;
struct avr_irq_t;

namespace chip_16u2 {

constexpr uint32_t kHz = 16000000;        // the 16U2's crystal on the Uno and Mega R3
constexpr uint64_t kFrameCycles = 16000;  // one 1 ms full-speed USB frame in its cycles

// A byte the firmware handed USART1: the cycle it entered the shift register (its start bit).
struct TxByte {
  uint64_t cycle;
  uint8_t byte;
};

class Chip {
 public:
  // Loads hex_path (Intel hex) and runs the firmware's start-up (50 ms). false and error when
  // the file or the core cannot be loaded or the firmware stops.
  bool load(const std::string &hex_path, std::string &error);
  ~Chip();

  // Bus reset, then SET_ADDRESS, SET_CONFIGURATION, SET_LINE_CODING (baud, 8N1) and
  // SET_CONTROL_LINE_STATE (DTR and RTS), as a host opening the port does. false and error
  // when a stage is not answered.
  bool enumerate(uint32_t baud, std::string &error);

  // Runs the firmware to cycle `to` (no-op when past). false when the core stopped.
  bool run_to(uint64_t to);
  uint64_t cycle() const;

  // One bulk OUT packet (at most 64 bytes) to the data endpoint: true when taken, false when
  // the endpoint NAKs (its bank still holds an earlier packet).
  bool bulk_out(const uint8_t *bytes, size_t count);
  // One bulk IN poll of the data endpoint: appends what the firmware released.
  void bulk_in(std::vector<uint8_t> &out);

  // Feeds bytes from the board into USART1's receiver back to back at the line's rate: the
  // first byte's stop bit comes one frame time from now (after bytes still coming in).
  void from_board(const uint8_t *bytes, size_t count);
  // USART1's frame time at the line coding the host set, cycles.
  uint64_t byte_cycles() const;

  // Bytes the firmware sent the board (oldest first); the caller may clear it.
  std::vector<TxByte> &sent() { return sent_; }

 private:
  bool control(uint8_t request_type, uint8_t request, uint16_t value, const uint8_t *data, uint16_t length,
               std::string &error);
  static void on_uart_output(avr_irq_t *irq, uint32_t value, void *param);

  avr_t *avr_ = nullptr;
  void *uart_ = nullptr;     // simavr's USART1 (avr_uart_t)
  uint64_t shift_free_ = 0;  // the cycle USART1's shift register is free again
  uint64_t udr_free_ = 0;    // the cycle its data register is empty again (UDRE1)
  std::vector<TxByte> sent_;
  // Board bytes not yet handed to simavr's receiver (its input FIFO holds 64): each goes in
  // one frame time before its stop bit, when the one before it is complete.
  std::deque<TxByte> to_uart_;
};

}  // namespace chip_16u2

#endif  // STEPCHOIR_BENCH_CHIP_16U2_H

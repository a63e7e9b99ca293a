// chip_16u2.cpp: the 16U2 bridge chip on simavr (see chip_16u2.h).
#include "chip_16u2.h"

#include <cstring>

extern "C" {
#include <simavr/avr_uart.h>
#include <simavr/avr_usb.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_hex.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>
}

#include "avr_uart_timing.h"

namespace chip_16u2 {
namespace {

constexpr uint8_t kDataOutEndpoint = 4;  // CDC_RX_EPNUM in the firmware's Descriptors.h
constexpr uint8_t kDataInEndpoint = 3;   // CDC_TX_EPNUM
constexpr uint8_t kUdreBit = 5;          // UDRE1 in UCSR1A
constexpr uint64_t kUs = kHz / 1000000;

int usb_ioctl(avr_t *avr, uint32_t ctl, uint8_t pipe, uint8_t *buf, uint32_t &size) {
  avr_io_usb io{pipe, size, buf};
  const int r = avr_ioctl(avr, ctl, &io);
  size = io.sz;
  return r;
}

}  // namespace

Chip::~Chip() {
  if (avr_) avr_terminate(avr_);
}

bool Chip::load(const std::string &hex_path, std::string &error) {
  avr_ = avr_make_mcu_by_name("at90usb162");
  if (!avr_) {
    error = "simavr has no at90usb162 core";
    return false;
  }
  avr_init(avr_);
  avr_->frequency = kHz;
  ihex_chunk_p chunks = nullptr;
  const int count = read_ihex_chunks(hex_path.c_str(), &chunks);
  if (count <= 0) {
    error = hex_path + ": not an Intel hex file";
    return false;
  }
  for (int i = 0; i < count; ++i) avr_loadcode(avr_, chunks[i].data, chunks[i].size, chunks[i].baseaddr);
  free_ihex_chunks(chunks);
  for (avr_io_t *io = avr_->io_port; io; io = io->next)
    if (std::strcmp(io->kind, "uart") == 0 && reinterpret_cast<avr_uart_t *>(io)->name == '1') uart_ = io;
  if (!uart_) {
    error = "simavr's at90usb162 core has no USART1";
    return false;
  }
  uint32_t flags = 0;  // no console echo, no host sleep while the firmware polls
  avr_ioctl(avr_, AVR_IOCTL_UART_GET_FLAGS('1'), &flags);
  flags &= ~(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('1'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_OUTPUT), on_uart_output, this);
  if (!run_to(50000 * kUs)) {
    error = hex_path + ": the firmware stopped during its start-up";
    return false;
  }
  return true;
}

// USART1's data register as the chip has it (simavr 1.6 lets a UCSR1A write clear UDRE1 and
// has no transmit double buffer): empty once the byte written last entered the shift register.
bool Chip::run_to(uint64_t to) {
  avr_uart_t *uart = static_cast<avr_uart_t *>(uart_);
  uint8_t &ucsra = avr_->data[uart->udrc.raised.reg];
  avr_irq_t *input = avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_INPUT);
  while (avr_->cycle < to) {
    while (!to_uart_.empty() && to_uart_.front().cycle <= avr_->cycle) {
      avr_raise_irq(input, to_uart_.front().byte);
      to_uart_.pop_front();
    }
    if (avr_->cycle >= udr_free_) ucsra |= 1 << kUdreBit;
    else ucsra &= ~(1 << kUdreBit);
    const int state = avr_run(avr_);
    if (state == cpu_Done || state == cpu_Crashed) return false;
  }
  return true;
}

uint64_t Chip::cycle() const { return avr_->cycle; }

uint64_t Chip::byte_cycles() const { return vboard::uart_byte_cycles(avr_, static_cast<avr_uart_t *>(uart_)); }

void Chip::on_uart_output(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  Chip *self = static_cast<Chip *>(param);
  const uint64_t now = self->avr_->cycle;
  const uint64_t start = now > self->shift_free_ ? now : self->shift_free_;
  self->sent_.push_back({start, static_cast<uint8_t>(value)});
  self->shift_free_ = start + self->byte_cycles();
  self->udr_free_ = start;
}

// A control transfer: SETUP, an OUT data stage when length > 0, and the IN status stage (a
// zero-length packet the firmware arms once it has handled the request). The firmware handles
// control requests in its USB_COM interrupt (LUFA's INTERRUPT_CONTROL_ENDPOINT), spinning there
// until the host takes the status stage.
bool Chip::control(uint8_t request_type, uint8_t request, uint16_t value, const uint8_t *data, uint16_t length,
                   std::string &error) {
  uint8_t setup[8] = {request_type, request, uint8_t(value), uint8_t(value >> 8), 0, 0, uint8_t(length),
                      uint8_t(length >> 8)};
  uint32_t size = sizeof setup;
  const std::string what = "control request " + std::to_string(request);
  if (usb_ioctl(avr_, AVR_IOCTL_USB_SETUP, 0, setup, size) != 0) {
    error = what + ": SETUP refused";
    return false;
  }
  auto retry = [&](uint32_t ctl, uint8_t pipe, uint8_t *buf, uint32_t bytes) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      if (!run_to(avr_->cycle + 50 * kUs)) return false;
      uint32_t n = bytes;
      if (usb_ioctl(avr_, ctl, pipe, buf, n) == 0) return true;
    }
    return false;
  };
  uint8_t buf[64];
  if (length > 0) {
    std::memcpy(buf, data, length);
    if (!retry(AVR_IOCTL_USB_WRITE, 0, buf, length)) {
      error = what + ": its data stage was not taken";
      return false;
    }
  }
  if (!retry(AVR_IOCTL_USB_READ, 0x80, buf, sizeof buf)) {
    error = what + ": no status stage";
    return false;
  }
  return run_to(avr_->cycle + 200 * kUs);
}

bool Chip::enumerate(uint32_t baud, std::string &error) {
  avr_ioctl(avr_, AVR_IOCTL_USB_RESET, nullptr);
  if (!run_to(avr_->cycle + 1000 * kUs)) {
    error = "the firmware stopped after the bus reset";
    return false;
  }
  const uint8_t line_coding[7] = {uint8_t(baud), uint8_t(baud >> 8), uint8_t(baud >> 16), uint8_t(baud >> 24),
                                  0 /* one stop bit */, 0 /* no parity */, 8 /* data bits */};
  return control(0x00, 5, 1, nullptr, 0, error)                    // SET_ADDRESS 1
         && control(0x00, 9, 1, nullptr, 0, error)                 // SET_CONFIGURATION 1
         && control(0x21, 0x20, 0, line_coding, 7, error)          // CDC SET_LINE_CODING
         && control(0x21, 0x22, 3, nullptr, 0, error)              // CDC SET_CONTROL_LINE_STATE: DTR, RTS
         && run_to(avr_->cycle + 5000 * kUs);
}

bool Chip::bulk_out(const uint8_t *bytes, size_t count) {
  uint8_t buf[64];
  std::memcpy(buf, bytes, count);
  uint32_t size = static_cast<uint32_t>(count);
  return usb_ioctl(avr_, AVR_IOCTL_USB_WRITE, kDataOutEndpoint, buf, size) == 0;
}

void Chip::bulk_in(std::vector<uint8_t> &out) {
  uint8_t buf[64];
  uint32_t size = sizeof buf;
  if (usb_ioctl(avr_, AVR_IOCTL_USB_READ, 0x80 | kDataInEndpoint, buf, size) == 0) out.insert(out.end(), buf, buf + size);
}

void Chip::from_board(const uint8_t *bytes, size_t count) {
  const uint64_t frame = byte_cycles();
  static_cast<avr_uart_t *>(uart_)->cycles_per_byte = frame;
  uint64_t at = to_uart_.empty() ? avr_->cycle : to_uart_.back().cycle + frame;
  for (size_t i = 0; i < count; ++i, at += frame) to_uart_.push_back({at, bytes[i]});
}

}  // namespace chip_16u2

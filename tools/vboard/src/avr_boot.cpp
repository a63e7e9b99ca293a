// avr_boot.cpp: AvrAdapter's resets and bootloader. A real Uno or Mega resets when the host opens
// its port (DTR pulses RESET through a capacitor), and its bootloader then waits for a
// programmer before it starts the firmware; the bytes the host sends meanwhile are lost. The
// model keeps what the firmware and the host meet: how long the bootloader holds the board
// (BoardConfig::bootloader_ms, with its sources) with the UART off, then a start at address 0.
#include <cstdint>

extern "C" {
#include <simavr/sim_avr.h>
}

#include "avr_adapter.h"
#include "cpu_profiler.h"

namespace vboard {

namespace {

// MCUSR (I/O 0x34, data address 0x54 on the ATmega328P and the ATmega2560) and its external
// reset bit.
constexpr uint16_t kMcusrDataAddress = 0x54;
constexpr uint8_t kExtrf = 1 << 1;
// `rjmp .` (a jump to itself): the bootloader's idle loop, in the flash's last word (the boot
// section's end, which the firmware never reaches).
constexpr uint16_t kRjmpSelf = 0xCFFF;

}  // namespace

void AvrAdapter::hold_in_bootloader(uint64_t cycles) {
  if (cycles == 0) return;
  const uint32_t loop = avr_->flashend - 1;
  avr_->flash[loop] = kRjmpSelf & 0xff;
  avr_->flash[loop + 1] = kRjmpSelf >> 8;
  avr_->pc = loop;
  boot_end_cycle_ = avr_->cycle + cycles;
  in_bootloader_ = true;
}

void AvrAdapter::leave_bootloader_when_done() {
  if (!in_bootloader_ || avr_->cycle < boot_end_cycle_) return;
  in_bootloader_ = false;
  avr_->pc = 0;  // as the bootloader's jump to the application
}

void AvrAdapter::reset_by_host(uint64_t bootloader_cycles) {
  avr_reset(avr_);
  relax_level_interrupts();
  avr_->data[kMcusrDataAddress] = kExtrf;
  in_bootloader_ = false;
  if (profiler_) profiler_->on_reset(avr_->cycle);
  maintain();  // the reset cleared the switch levels' PIN bits and our cycle timers
  hold_in_bootloader(bootloader_cycles);
}

}  // namespace vboard

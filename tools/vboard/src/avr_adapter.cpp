// avr_adapter.cpp: simavr glue: MCU setup, log, pin and switch hooks, cycle timers (UART0 in avr_uart.cpp).
#include "avr_adapter.h"

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include <simavr/avr_eeprom.h>
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
}

namespace vboard {

namespace {

bool g_log_quiet = false;

// simavr log sink: everything to stderr (never stdout, which carries only the pty line).
void log_to_stderr(avr_t *avr, const int level, const char *format, va_list args) {
  (void)avr;
  if (level > (g_log_quiet ? LOG_ERROR : LOG_WARNING)) return;
  std::fputs("simavr: ", stderr);
  std::vfprintf(stderr, format, args);
}

}  // namespace

// One watched output pin: adapter + index into VirtualBoard::watched_pins().
struct AvrAdapter::PinHook {
  AvrAdapter *adapter;
  size_t watched_index;
};

// External drive state of one port's switch pins (simavr keeps it per port).
struct AvrAdapter::SwitchPort {
  char port;
  avr_ioport_t *module;
  uint8_t mask;
  uint8_t value;
};

// model and link must outlive the adapter.
AvrAdapter::AvrAdapter(const BoardConfig &board, VirtualBoard &model, PtyLink &link)
    : board_(board), model_(model), link_(link) {}

// Frees the simulated MCU.
AvrAdapter::~AvrAdapter() {
  if (avr_) avr_terminate(avr_);
}

// Routes simavr's log to stderr.
void AvrAdapter::install_logger(bool quiet) {
  g_log_quiet = quiet;
  avr_global_logger_set(&log_to_stderr);
}

// Creates the MCU, loads the ELF, sets initial levels and hooks everything.
bool AvrAdapter::load(const std::string &elf_path, std::string &error) {
  elf_firmware_t firmware;
  std::memset(&firmware, 0, sizeof firmware);
  if (elf_read_firmware(elf_path.c_str(), &firmware) != 0) {
    error = "cannot load firmware " + elf_path;
    return false;
  }
  avr_ = avr_make_mcu_by_name(board_.mcu.c_str());
  if (!avr_) {
    error = "simavr does not know MCU " + board_.mcu;
    return false;
  }
  avr_init(avr_);
  avr_->log = LOG_WARNING;
  firmware.frequency = board_.f_cpu_hz;
  std::snprintf(firmware.mmcu, sizeof firmware.mmcu, "%s", board_.mcu.c_str());
  avr_load_firmware(avr_, &firmware);
  avr_->frequency = board_.f_cpu_hz;
  avr_->sleep = &AvrAdapter::no_sleep;  // pacing is ours; never usleep inside the core
  relax_level_interrupts();
  if (!find_modules(error)) return false;
  apply_initial_levels();
  hook_callbacks();
  fix_uart_timing();
  return true;
}

// simavr's EEPROM ioctls return -1 when they did their work and -2 for a bad request; some
// versions refuse a request that reaches the EEPROM's last byte, so that byte is then left out.
// 0 when done.
int AvrAdapter::eeprom_ioctl(uint32_t ctl, avr_eeprom_desc_t *desc) {
  if (avr_ioctl(avr_, ctl, desc) != -2) return 0;
  if (desc->size < 2) return -1;
  --desc->size;
  return avr_ioctl(avr_, ctl, desc) != -2 ? 0 : -1;
}

bool AvrAdapter::load_eeprom(const std::string &path, std::string &error) {
  std::FILE *f = std::fopen(path.c_str(), "rb");
  if (!f) return true;  // a new board: erased
  std::vector<uint8_t> bytes(board_.eeprom_bytes, 0xFF);
  const size_t n = std::fread(bytes.data(), 1, bytes.size(), f);
  const bool read_error = std::ferror(f) != 0;
  std::fclose(f);
  if (read_error) {
    error = path + ": cannot read the EEPROM file";
    return false;
  }
  if (n == 0) return true;
  avr_eeprom_desc_t desc{bytes.data(), 0, static_cast<uint32_t>(n)};
  if (eeprom_ioctl(AVR_IOCTL_EEPROM_SET, &desc) != 0) {
    error = path + ": simavr refused the EEPROM contents";
    return false;
  }
  return true;
}

bool AvrAdapter::save_eeprom(const std::string &path, std::string &error) {
  std::vector<uint8_t> bytes(board_.eeprom_bytes, 0xFF);
  avr_eeprom_desc_t desc{bytes.data(), 0, static_cast<uint32_t>(bytes.size())};
  if (eeprom_ioctl(AVR_IOCTL_EEPROM_GET, &desc) != 0) {
    error = "simavr gave no EEPROM contents";
    return false;
  }
  // simavr either copies into ee or points ee at its own bytes.
  const uint8_t *from = desc.ee ? desc.ee : bytes.data();
  std::FILE *f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(from, 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0) {
    if (f) std::fclose(f);
    error = path + ": cannot write the EEPROM file";
    return false;
  }
  return true;
}

// simavr polls a low INTn pin every cycle in level mode (what every reset sets), even with the
// interrupt disabled; INT0/INT1 are the X/Y STEP pins on the Uno, low most of the time, and the
// polling makes the run 5x slower. With strict mode off a level-mode INTn fires on the falling
// edge only.
void AvrAdapter::relax_level_interrupts() {
  for (uint8_t int_number = 0; int_number < EXTINT_COUNT; ++int_number)
    avr_extint_set_strict_lvl_trig(avr_, int_number, 0);
}

// Looks up simavr's UART0 and the port modules of the switch pins; clears UART stdio/poll-sleep.
bool AvrAdapter::find_modules(std::string &error) {
  for (avr_io_t *io = avr_->io_port; io; io = io->next) {
    if (std::strcmp(io->kind, "uart") == 0 && reinterpret_cast<avr_uart_t *>(io)->name == '0')
      uart_ = io;
  }
  if (!uart_) {
    error = "simavr core " + board_.mcu + " has no UART0";
    return false;
  }
  uint32_t flags = 0;
  avr_ioctl(avr_, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~static_cast<uint32_t>(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  uart_input_irq_ = avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);

  for (const SwitchInput &input : model_.switch_inputs()) {
    avr_irq_t *irq = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(input.pin.port), input.pin.bit);
    if (!irq) {
      error = std::string("simavr core has no port ") + input.pin.port;
      return false;
    }
    switch_irqs_.push_back(irq);
    bool known = false;
    for (const SwitchPort &sp : switch_ports_) known = known || sp.port == input.pin.port;
    if (known) continue;
    avr_ioport_t *module = nullptr;
    for (avr_io_t *io = avr_->io_port; io; io = io->next)
      if (std::strcmp(io->kind, "port") == 0 && reinterpret_cast<avr_ioport_t *>(io)->name == input.pin.port)
        module = reinterpret_cast<avr_ioport_t *>(io);
    if (!module) {
      error = std::string("simavr core has no port module ") + input.pin.port;
      return false;
    }
    switch_ports_.push_back({input.pin.port, module, 0, 0});
  }
  return true;
}

// Sets the levels the firmware sees before its first instruction.
void AvrAdapter::apply_initial_levels() {
  for (size_t s = 0; s < model_.switch_inputs().size(); ++s)
    drive_switch_pin(s, model_.switch_inputs()[s].contact.pin_level());
  for (const WatchedPin &watched : model_.watched_pins()) {
    avr_irq_t *irq = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(watched.pin.port), watched.pin.bit);
    if (irq && watched.initial_level) avr_raise_irq(irq, 1);  // e.g. ENABLE pulled up
  }
}

// Registers the pin, UART and XON/XOFF callbacks.
void AvrAdapter::hook_callbacks() {
  const std::vector<WatchedPin> &watched = model_.watched_pins();
  for (size_t i = 0; i < watched.size(); ++i) {
    avr_irq_t *irq = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(watched[i].pin.port), watched[i].pin.bit);
    if (!irq) continue;
    pin_hooks_.push_back(std::unique_ptr<PinHook>(new PinHook{this, i}));
    avr_irq_register_notify(irq, &AvrAdapter::on_pin_irq, pin_hooks_.back().get());
  }
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                          &AvrAdapter::on_uart_output, this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                          &AvrAdapter::on_uart_xon, this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                          &AvrAdapter::on_uart_xoff, this);
  // After simavr's own handler of the register (registered first, it stores the value).
  avr_register_io_write(avr_, static_cast<avr_uart_t *>(uart_)->rxc.enable.reg, &AvrAdapter::on_rxcie_write, this);
}

// Flash size in bytes.
uint32_t AvrAdapter::flash_bytes() const { return avr_->flashend + 1; }

// Bytes per interrupt vector slot.
unsigned AvrAdapter::vector_size_bytes() const { return avr_->vector_size; }

// Current cycle.
uint64_t AvrAdapter::cycle() const { return avr_->cycle; }

// SREG.I now.
bool AvrAdapter::interrupts_enabled() const { return avr_->sreg[S_I] != 0; }

// Makes a sleeping core stop at end_cycle instead of jumping past it.
void AvrAdapter::set_end_cycle(uint64_t end_cycle) {
  end_cycle_ = end_cycle;
  if (end_cycle_ != UINT64_MAX && avr_->cycle < end_cycle_)
    avr_cycle_timer_register(avr_, end_cycle_ - avr_->cycle, &AvrAdapter::on_end_timer, this);
}

// Between chunks: restores switch levels in the PIN registers and our cycle timers, which an
// MCU reset (e.g. the watchdog) clears.
void AvrAdapter::maintain() {
  const std::vector<SwitchInput> &inputs = model_.switch_inputs();
  for (size_t s = 0; s < inputs.size(); ++s) {
    avr_ioport_t *module = nullptr;
    for (const SwitchPort &sp : switch_ports_)
      if (sp.port == inputs[s].pin.port) module = sp.module;
    if (!module) continue;
    const uint8_t mask = static_cast<uint8_t>(1u << inputs[s].pin.bit);
    uint8_t &pin_register = avr_->data[module->r_pin];
    pin_register = inputs[s].contact.pin_level() ? (pin_register | mask) : (pin_register & ~mask);
  }
  if (rx_timer_armed_ && avr_cycle_timer_status(avr_, &AvrAdapter::on_rx_timer, this) == 0) {
    rx_timer_armed_ = false;
    kick_rx();
  }
  if (wake_armed_ && avr_cycle_timer_status(avr_, &AvrAdapter::on_wake_timer, this) == 0) {
    wake_armed_ = false;
    wake_at(wake_cycle_);
  }
  if (end_cycle_ != UINT64_MAX && avr_->cycle < end_cycle_ &&
      avr_cycle_timer_status(avr_, &AvrAdapter::on_end_timer, this) == 0)
    set_end_cycle(end_cycle_);
}

// Sets a switch input level now: as the port's external drive (so PORT writes and pull-ups do
// not override it) and on the pin itself.
void AvrAdapter::drive_switch_pin(size_t switch_index, bool level) {
  const PinRef &pin = model_.switch_inputs()[switch_index].pin;
  for (SwitchPort &sp : switch_ports_) {
    if (sp.port != pin.port) continue;
    const uint8_t mask = static_cast<uint8_t>(1u << pin.bit);
    sp.mask |= mask;
    sp.value = level ? (sp.value | mask) : (sp.value & ~mask);
    avr_ioport_external_t external;
    std::memset(&external, 0, sizeof external);
    external.name = static_cast<unsigned>(sp.port) & 0x7f;
    external.mask = sp.mask;
    external.value = sp.value;
    avr_ioctl(avr_, AVR_IOCTL_IOPORT_SET_EXTERNAL(sp.port), &external);
  }
  avr_raise_irq(switch_irqs_[switch_index], level ? 1 : 0);
}

// Asks for VirtualBoard::on_wakeup at cycle (keeps the earliest request).
void AvrAdapter::wake_at(uint64_t cycle) {
  if (wake_armed_ && wake_cycle_ <= cycle) return;
  const uint64_t now = avr_->cycle;
  avr_cycle_timer_register(avr_, cycle > now ? cycle - now : 1, &AvrAdapter::on_wake_timer, this);
  wake_armed_ = true;
  wake_cycle_ = cycle;
}

// A watched output pin changed (simavr filters repeats, the model ignores them too).
void AvrAdapter::on_pin_irq(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  PinHook *hook = static_cast<PinHook *>(param);
  hook->adapter->model_.on_output_pin(hook->watched_index, value != 0, hook->adapter->avr_->cycle);
}

// Time for the model's switch events.
uint64_t AvrAdapter::on_wake_timer(avr_t *avr, uint64_t when, void *param) {
  (void)when;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  self->wake_armed_ = false;
  self->model_.on_wakeup(avr->cycle);
  return 0;
}

// Marks the end of the run so a sleeping core does not jump past it.
uint64_t AvrAdapter::on_end_timer(avr_t *avr, uint64_t when, void *param) {
  (void)avr;
  (void)when;
  (void)param;
  return 0;
}

// Replaces simavr's sleep callback: the main loop paces against the wall clock itself.
void AvrAdapter::no_sleep(avr_t *avr, uint64_t how_long_cycles) {
  (void)avr;
  (void)how_long_cycles;
}

}  // namespace vboard

// avr_adapter.cpp: simavr glue: MCU setup, pin and UART callbacks, cycle timers, the run loop.
#include "avr_adapter.h"

#include <cstdarg>
#include <array>
#include <cstdio>
#include <string>
#include <vector>
#include <cstring>
#include <cstdlib>

#include <unistd.h>

extern "C" {
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_regbit.h>
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

// RETI opcode (little-endian word 0x9518).
inline bool is_reti(const uint8_t *flash, uint32_t pc_bytes) {
  return flash[pc_bytes] == 0x18 && flash[pc_bytes + 1] == 0x95;
}

// True when the core will not run any more.
inline bool core_stopped(int state) {
  return state == cpu_Done || state == cpu_Crashed || state == cpu_Stopped;
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
  // simavr polls a low INTn pin every cycle in level mode (the reset default), even with the
  // interrupt disabled; INT0/INT1 are the X/Y STEP pins on the Uno, low most of the time. That
  // made the run 5x slower. With strict mode off a level-mode INTn fires on the falling edge only.
  for (uint8_t int_number = 0; int_number < EXTINT_COUNT; ++int_number)
    avr_extint_set_strict_lvl_trig(avr_, int_number, 0);
  if (!find_modules(error)) return false;
  apply_initial_levels();
  hook_callbacks();
  fix_uart_timing();
  return true;
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

// The AVR wrote the register holding RXCIE0 (UCSR0B). On a real chip the receive interrupt is
// the level RXC0 AND RXCIE0: turned on while a byte waits, it is taken at once. simavr 1.6 marks
// the interrupt pending only when it raises RXC0 (when a byte comes in, and again every byte time
// while its buffer holds one), so a byte waiting when RXCIE0 came on waited up to a byte time
// more. Here it is made pending at once, as on the chip (`ctest -R vboard_uart_rxcie`).
void AvrAdapter::on_rxcie_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  (void)addr;
  (void)v;
  avr_uart_t *uart = static_cast<avr_uart_t *>(static_cast<AvrAdapter *>(param)->uart_);
  if (avr_regbit_get(avr, uart->rxc.enable) && avr_regbit_get(avr, uart->rxc.raised) && !uart->rxc.pending)
    avr_raise_interrupt(avr, &uart->rxc);
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

namespace {
// Cycles spent at each flash address, written at exit (see STEPCHOIR_VBOARD_PCPROFILE).
struct PcProfile {
  std::string path;
  std::vector<uint64_t> cycles;
  // Called from: run_until, once. Empty path: counts nothing.
  PcProfile(const char *p, size_t flash_bytes) : path(p ? p : ""), cycles(p ? flash_bytes : 0) {}
  // Called from: run_until, every step.
  void add(uint32_t pc_bytes, uint64_t n) {
    if (pc_bytes < cycles.size()) cycles[pc_bytes] += n;
  }
  ~PcProfile() {
    if (path.empty()) return;
    path = with_pid(path);
    if (FILE *f = std::fopen(path.c_str(), "w")) {
      for (size_t a = 0; a < cycles.size(); ++a)
        if (cycles[a]) std::fprintf(f, "%zx %llu\n", a, static_cast<unsigned long long>(cycles[a]));
      std::fclose(f);
    }
  }
};

// The last 65,536 instructions ("cycle pc I", see STEPCHOIR_VBOARD_PCTRACE), written when the
// core crashes or, with a watched RAM byte, each time that byte changes.
struct PcTrace {
  static constexpr size_t kSteps = 65536;  // a power of two: the ring index is masked
  std::string path;
  std::vector<std::array<uint32_t, 3>> ring;
  size_t next = 0;
  long watch = -1;         // RAM address watched, or -1
  uint64_t after = 0;      // watch from this cycle on
  int max_dumps = 20, dumps = 0;
  int last = -1;           // the watched byte's value at the previous step
  // Called from: run_until, once. Null path: records nothing.
  explicit PcTrace(const char *p) : path(p ? with_pid(p) : ""), ring(p ? kSteps : 0) {
    if (!p) return;
    if (const char *w = std::getenv("STEPCHOIR_VBOARD_PCTRACE_WATCH")) watch = std::strtol(w, nullptr, 0);
    if (const char *a = std::getenv("STEPCHOIR_VBOARD_PCTRACE_AFTER")) after = std::strtoull(a, nullptr, 0);
    if (const char *m = std::getenv("STEPCHOIR_VBOARD_PCTRACE_MAX")) max_dumps = std::atoi(m);
  }
  // Called from: run_until, every step. True when the watched byte changed: dump now.
  bool record(const avr_t *avr) {
    ring[next++ & (kSteps - 1)] = {static_cast<uint32_t>(avr->cycle), avr->pc, avr->sreg[S_I]};
    if (watch < 0 || watch > avr->ramend || dumps >= max_dumps) return false;
    const int v = avr->data[watch];
    const bool changed = last >= 0 && v != last && avr->cycle >= after;
    last = v;
    return changed;
  }
  // Called from: run_until, when record() said so. Writes PATH.1, PATH.2, ... and the RAM as it
  // is right after the change to PATH.1.ram, PATH.2.ram, ...
  void dump(const avr_t *avr) {
    const std::string file = path + "." + std::to_string(++dumps);
    write(file);
    write_ram(file + ".ram", avr);
  }
  // Writes the data space (registers, I/O, RAM: ramend + 1 bytes) to file.
  static void write_ram(const std::string &file, const avr_t *avr) {
    if (FILE *f = std::fopen(file.c_str(), "wb")) {
      std::fwrite(avr->data, 1, avr->ramend + 1, f);
      std::fclose(f);
    }
  }
  // Writes the ring to file, oldest first.
  void write(const std::string &file) const {
    if (FILE *f = std::fopen(file.c_str(), "w")) {
      for (size_t i = 0; i < kSteps; ++i) {
        const auto &e = ring[(next + i) & (kSteps - 1)];
        std::fprintf(f, "%u %x %u\n", e[0], e[1], e[2]);
      }
      std::fclose(f);
    }
  }
};
}  // namespace

// Runs until cycle >= end_cycle or the core stops. With a profiler, every step is sampled.
CoreState AvrAdapter::run_until(uint64_t end_cycle) {
  avr_t *const avr = avr_;
  int state = avr->state;
  if (!profiler_) {
    while (avr->cycle < end_cycle && !core_stopped(state)) state = avr_run(avr);
  } else {
    CpuProfiler &profiler = *profiler_;
    const uint8_t *const flash = avr->flash;
    InstructionSample s;
    // Debugging aid: STEPCHOIR_VBOARD_PCTRACE=PATH ("%p": the process id) keeps the last
    // PcTrace::kSteps steps ("cycle pc I") and writes them to PATH (and RAM to PATH.ram) when
    // the core crashes; with STEPCHOIR_VBOARD_PCTRACE_WATCH=ADDR also to PATH.1, PATH.2, ...
    // (RAM to PATH.1.ram, ...) each time the RAM byte at ADDR changes (see docs/ARCHITECTURE.md, "Debugging aids").
    static PcTrace pc_trace(std::getenv("STEPCHOIR_VBOARD_PCTRACE"));
    // Debugging aid: STEPCHOIR_VBOARD_PCPROFILE=PATH counts the cycles spent at each flash
    // address and writes "address cycles" lines (hex, nonzero only) to PATH at exit ("%p" in
    // PATH becomes the process id); map them
    // to functions with avr-addr2line or avr-objdump -d.
    static PcProfile pc_profile(std::getenv("STEPCHOIR_VBOARD_PCPROFILE"), avr->flashend + 1);
    const bool tracing = !pc_trace.path.empty();  // a register, not a load, every step
    while (avr->cycle < end_cycle && !core_stopped(state)) {
      if (tracing && pc_trace.record(avr)) pc_trace.dump(avr);
      s.pc_before_bytes = avr->pc;
      s.cycle_before = avr->cycle;
      s.i_before = avr->sreg[S_I] != 0;
      s.executed = state == cpu_Running;
      state = avr_run(avr);
      s.pc_after_bytes = avr->pc;
      s.cycle_after = avr->cycle;
      s.i_after = avr->sreg[S_I] != 0;
      s.was_reti = s.executed && profiler.in_isr() && is_reti(flash, s.pc_before_bytes);
      profiler.on_step(s);
      pc_profile.add(s.pc_before_bytes, s.cycle_after - s.cycle_before);
    }
    if (tracing && core_stopped(state)) {
      pc_trace.write(pc_trace.path);
      PcTrace::write_ram(pc_trace.path + ".ram", avr);
    }
  }
  if (state == cpu_Done) return CoreState::kDone;
  if (state == cpu_Crashed || state == cpu_Stopped) return CoreState::kCrashed;
  return CoreState::kRunning;
}

// Starts feeding received host bytes to UART0, one per byte time.
void AvrAdapter::kick_rx() {
  if (rx_timer_armed_ || xoff_ || (repeat_byte_ < 0 && !link_.rx_pending())) return;
  const uint64_t now = avr_->cycle;
  const uint64_t delay_cycles = next_rx_cycle_ > now ? next_rx_cycle_ - now : 1;
  avr_cycle_timer_register(avr_, delay_cycles, &AvrAdapter::on_rx_timer, this);
  rx_timer_armed_ = true;
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

// UART0 byte time in cycles: (UBRR+1) * (U2X ? 8 : 16) per bit, start + data + parity + stop bits.
uint64_t AvrAdapter::uart_byte_cycles() const {
  const avr_uart_t *uart = static_cast<const avr_uart_t *>(uart_);
  const uint8_t *data = avr_->data;
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

// simavr 1.6 computes the byte time only when UBRRnL is written (never if the firmware keeps the
// reset value 0) and always counts a parity bit: set it from the registers before each byte.
void AvrAdapter::fix_uart_timing() {
  static_cast<avr_uart_t *>(uart_)->cycles_per_byte = uart_byte_cycles();
}

// A watched output pin changed (simavr filters repeats, the model ignores them too).
void AvrAdapter::on_pin_irq(avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  PinHook *hook = static_cast<PinHook *>(param);
  hook->adapter->model_.on_output_pin(hook->watched_index, value != 0, hook->adapter->avr_->cycle);
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
  self->link_.tx_push(static_cast<uint8_t>(value));
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

// Delivers one host byte to UART0; reschedules itself one byte time later while bytes remain.
uint64_t AvrAdapter::on_rx_timer(avr_t *avr, uint64_t when, void *param) {
  (void)when;
  AvrAdapter *self = static_cast<AvrAdapter *>(param);
  if (self->xoff_ || (self->repeat_byte_ < 0 && !self->link_.rx_pending())) {
    self->rx_timer_armed_ = false;  // XON (or the next poll) restarts it
    return 0;
  }
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
    if (byte == 0 && self->frame_trace_) self->frame_trace_->frame_end(avr->cycle);
  } else if (deliver) {
    ++self->uart_in_lost_;  // receiver off: the byte is lost, as on the real chip
  }
  self->next_rx_cycle_ = avr->cycle + self->uart_byte_cycles();
  if (self->xoff_ || (self->repeat_byte_ < 0 && !self->link_.rx_pending())) {
    self->rx_timer_armed_ = false;
    return 0;
  }
  return self->next_rx_cycle_;
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

// avr_adapter.h: the only simavr user: runs the ELF, reports pins, drives switches, bridges UART0.
#ifndef STEPCHOIR_VBOARD_AVR_ADAPTER_H
#define STEPCHOIR_VBOARD_AVR_ADAPTER_H

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "board_config.h"
#include "cpu_profiler.h"
#include "line_noise.h"
#include "pacer.h"
#include "pty_link.h"
#include "virtual_board.h"

struct avr_t;
struct avr_irq_t;
struct avr_eeprom_desc_t;

namespace vboard {

// How the simulated core ended a run_until() call.
enum class CoreState { kRunning, kDone, kCrashed };

// Thin adapter between simavr and the pure model. Pin callbacks, switch levels, the UART bridge
// and cycle timers all go through here; the model never sees simavr types.
class AvrAdapter : public SwitchPinDriver {
 public:
  // model and link must outlive the adapter.
  AvrAdapter(const BoardConfig &board, VirtualBoard &model, PtyLink &link);
  ~AvrAdapter() override;
  AvrAdapter(const AvrAdapter &) = delete;
  AvrAdapter &operator=(const AvrAdapter &) = delete;

  // Routes simavr's log to stderr (errors only when quiet). Call before load().
  static void install_logger(bool quiet);
  // Creates the MCU, loads elf_path, sets initial pin levels and hooks pins and UART0.
  bool load(const std::string &elf_path, std::string &error);
  // The EEPROM as a file (--eeprom), so a board keeps its id from run to run: load_eeprom
  // fills it from path if the file exists (after load(); a shorter file fills the start),
  // save_eeprom writes it whole. False with error when the file cannot be read or written.
  bool load_eeprom(const std::string &path, std::string &error);
  bool save_eeprom(const std::string &path, std::string &error);
  // The board's bootloader, as what it does to the firmware and the host: for `cycles` from
  // now the core runs an idle loop in the boot section with the UART off (host bytes that come
  // meanwhile are lost), then the firmware starts from address 0. Called after load(): at
  // power-on (a Mega's bootloader waits then too), and by reset_by_host.
  void hold_in_bootloader(uint64_t cycles);
  // A host byte that reaches the bootloader holds it until `cycles` after that byte (a Mega's
  // stk500v2; 0, the default: bytes do not hold it). Called after load().
  void set_bootloader_quiet(uint64_t cycles) { boot_quiet_cycles_ = cycles; }
  // Called from: the run loop, between chunks. Starts the firmware once the bootloader's time
  // is out (to a chunk).
  void leave_bootloader_when_done();
  // Resets the MCU as DTR's pulse on RESET does when the host opens the port (MCUSR EXTRF),
  // the bootloader first for bootloader_cycles (0: none).
  void reset_by_host(uint64_t bootloader_cycles);
  // Feeds every step to profiler (nullptr = no per-instruction accounting).
  void set_profiler(CpuProfiler *profiler) { profiler_ = profiler; }
  // Applies faults to every host byte (nullptr = a clean line). Must outlive the adapter.
  void set_line_noise(LineNoise *noise) { noise_ = noise; }
  // Writes a trace row whenever a frame delimiter (0x00) reaches UART0 (nullptr = none).
  void set_frame_trace(TraceWriter *trace) { frame_trace_ = trace; }
  // The host's time of each cycle, for the USB bridge: a host byte reaches UART0 on the cycle
  // the bridge releases it, a board byte is stamped with the cycle it was sent on, and a run
  // ends where the bridge passes board bytes to the host. Must outlive the adapter; until it is
  // set, the link's now (set between chunks) stands for every cycle and runs end where asked.
  void set_pacer(const Pacer *pacer) { pacer_ = pacer; }

  // Flash size in bytes.
  uint32_t flash_bytes() const;
  // Bytes per interrupt vector slot.
  unsigned vector_size_bytes() const;
  // Current cycle.
  uint64_t cycle() const;
  // SREG.I now.
  bool interrupts_enabled() const;
  // Makes a sleeping core stop at end_cycle instead of jumping past it (one cycle timer; a timer
  // per chunk would perturb simavr's wake-up timing, which depends on where timers fall).
  void set_end_cycle(uint64_t end_cycle);
  // Runs until cycle >= end_cycle, or the core stops, or (with a pacer) the bridge passes board
  // bytes to the host: the caller then flushes them (PtyLink::flush_tx) on their cycle. A
  // sleeping core jumps to its next timer, so it may pass end_cycle (except the one given to
  // set_end_cycle).
  CoreState run_until(uint64_t end_cycle);
  // Starts feeding received host bytes to UART0 (call after PtyLink::poll_rx()).
  void kick_rx();
  // Host bytes reach UART0 at most one per this many cycles, or one per byte time when that is
  // longer: the USB bridge's own pace (BridgeTiming::host_byte_ns). 0: the byte time.
  void set_rx_gap_cycles(uint64_t cycles) { rx_gap_cycles_ = cycles; }
  // Between chunks: re-writes the switch levels into the PIN registers and re-arms our cycle
  // timers if an MCU reset (watchdog) cleared them. Cheap.
  void maintain();

  // Bytes delivered to the AVR's receiver.
  uint64_t uart_in_bytes() const { return uart_in_bytes_; }
  // Host bytes lost because the AVR's receiver was disabled.
  uint64_t uart_in_lost() const { return uart_in_lost_; }
  // Times simavr's receive FIFO filled up (XOFF) and host bytes had to wait.
  uint64_t uart_xoff_count() const { return uart_xoff_count_; }
  // Host bytes that arrived while 3 earlier ones were still unread: a real ATmega (2-byte receive
  // buffer + shift register, no flow control from the USB bridge) would have lost one (DOR).
  uint64_t uart_would_overrun() const { return uart_would_overrun_; }
  // Bytes the AVR transmitted.
  uint64_t uart_out_bytes() const { return uart_out_bytes_; }

  // SwitchPinDriver: sets a switch input level now.
  void drive_switch_pin(size_t switch_index, bool level) override;
  // SwitchPinDriver: asks for VirtualBoard::on_wakeup at cycle.
  void wake_at(uint64_t cycle) override;

 private:
  int eeprom_ioctl(uint32_t ctl, ::avr_eeprom_desc_t *desc);
  struct PinHook;
  struct SwitchPort;

  // Looks up simavr's UART0 and port modules.
  bool find_modules(std::string &error);
  // Level-mode INTn interrupts on the falling edge only (after load and after every reset).
  void relax_level_interrupts();
  // Sets the initial pin levels the firmware sees.
  void apply_initial_levels();
  // Registers the pin, UART and XON/XOFF callbacks.
  void hook_callbacks();
  // The host's time (ns) at cycle: the pacer's, else the link's now.
  uint64_t host_ns(uint64_t cycle) const { return pacer_ ? pacer_->sim_ns(cycle) : link_.now_ns(); }
  // The cycle the next host byte reaches UART0 at, no sooner than `earliest`; 0 when none waits
  // or (without a pacer) it is not released yet.
  uint64_t rx_cycle(uint64_t earliest) const;
  // Ends the current run where the bridge next passes board bytes to the host (with a pacer).
  void end_run_at_tx_pass();
  // UART0 byte time in cycles from its current registers (start + data + parity + stop bits).
  uint64_t uart_byte_cycles() const;
  // Makes simavr time UART0 bytes correctly (it counts a parity bit always; see notes).
  void fix_uart_timing();

  // simavr callbacks (C signatures).
  static void on_pin_irq(avr_irq_t *irq, uint32_t value, void *param);
  static void on_uart_output(avr_irq_t *irq, uint32_t value, void *param);
  static void on_uart_xon(avr_irq_t *irq, uint32_t value, void *param);
  static void on_uart_xoff(avr_irq_t *irq, uint32_t value, void *param);
  static void on_rxcie_write(avr_t *avr, uint16_t addr, uint8_t v, void *param);  // addr: an avr_io_addr_t
  static uint64_t on_rx_timer(avr_t *avr, uint64_t when, void *param);
  static uint64_t on_udr_free_timer(avr_t *avr, uint64_t when, void *param);
  static uint64_t on_wake_timer(avr_t *avr, uint64_t when, void *param);
  static uint64_t on_end_timer(avr_t *avr, uint64_t when, void *param);
  static void no_sleep(avr_t *avr, uint64_t how_long_cycles);

  const BoardConfig &board_;
  VirtualBoard &model_;
  PtyLink &link_;
  CpuProfiler *profiler_ = nullptr;
  LineNoise *noise_ = nullptr;
  TraceWriter *frame_trace_ = nullptr;
  bool in_frame_ = false;            // host bytes reached UART0 since the last delimiter
  uint64_t frame_first_cycle_ = 0;   // when the first of them did (the frame trace's span)
  int repeat_byte_ = -1;  // a duplicated host byte still to deliver, or -1
  avr_t *avr_ = nullptr;
  void *uart_ = nullptr;  // avr_uart_t of UART0
  avr_irq_t *uart_input_irq_ = nullptr;
  std::vector<std::unique_ptr<PinHook>> pin_hooks_;
  std::vector<SwitchPort> switch_ports_;
  std::vector<avr_irq_t *> switch_irqs_;
  bool xoff_ = false;
  uint64_t tx_shift_free_cycle_ = 0;  // when UART0's transmit shift register is empty
  const Pacer *pacer_ = nullptr;
  uint64_t run_end_cycle_ = 0;  // run_until stops here; end_run_at_tx_pass may bring it closer
  bool rx_timer_armed_ = false;
  uint64_t next_rx_cycle_ = 0;
  uint64_t rx_gap_cycles_ = 0;
  bool wake_armed_ = false;
  uint64_t wake_cycle_ = 0;
  uint64_t end_cycle_ = UINT64_MAX;
  uint64_t uart_in_bytes_ = 0;
  uint64_t uart_in_lost_ = 0;
  uint64_t uart_out_bytes_ = 0;
  uint64_t uart_xoff_count_ = 0;
  uint64_t uart_would_overrun_ = 0;
  uint64_t boot_end_cycle_ = 0;  // the bootloader's idle loop runs until this cycle
  uint64_t boot_quiet_cycles_ = 0;  // set_bootloader_quiet
  bool in_bootloader_ = false;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_AVR_ADAPTER_H

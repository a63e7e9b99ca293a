// main.cpp: stepchoir-vboard: runs the firmware on a simulated board with a pty serial port.
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>

#include "avr_adapter.h"
#include "line_noise.h"
#include "board_config.h"
#include "cpu_profiler.h"
#include "elf_symbols.h"
#include "options.h"
#include "pacer.h"
#include "pty_link.h"
#include "usb_bridge.h"
#include "report.h"
#include "trace_writer.h"
#include "virtual_board.h"

namespace {

using namespace vboard;

volatile sig_atomic_t g_stop_signal = 0;
volatile sig_atomic_t g_reset_button = 0;  // SIGUSR1: the board's reset button was pressed

// Simulated time per loop chunk: the pty is polled and the trace flushed between chunks.
constexpr uint64_t kChunkUs = 20;
// The parent process and the host's open of the pty are looked at every this many chunks (about
// 1 ms).
constexpr uint64_t kCheckChunks = 1000 / kChunkUs;
// The simulation may run this far ahead of the wall clock before it sleeps; host bytes end the
// sleep (wait_until_ns), and are stamped with their wall time (host_arrival_ns). Host bytes come
// up to this late, the board's reach the host up to this early; a shorter lead costs more
// wake-ups (docs/decisions/020-vboard-pacing-catch-up.md).
constexpr int64_t kAheadBeforeSleepNs = 100 * 1000;
// When behind, at most this much is caught up in a burst; the rest is given up and reported.
// 50 ms absorbs the pauses of the machine running the board, so its clock keeps the wall's
// rate (docs/decisions/020-vboard-pacing-catch-up.md); the worst lag is still
// reported (pacing_lag_max_us).
constexpr uint64_t kMaxCatchupNs = 50 * 1000 * 1000;
// A lag behind real time beyond this (ns) is reported at exit: more than a USB frame, as much
// as the real-time checks of the end-to-end tests allow.
constexpr uint64_t kStallWarnNs = 2 * 1000 * 1000;
// The trace is written out at least this often (wall time).
constexpr uint64_t kTraceFlushNs = 250 * 1000 * 1000;

// SIGINT/SIGTERM/SIGHUP: ask the loop to stop.
void on_stop_signal(int signal_number) { g_stop_signal = signal_number; }
// SIGUSR1: the reset button (or a brown-out): the MCU restarts through its bootloader while
// the USB bridge, and so the host's link, stays up.
void on_reset_signal(int) { g_reset_button = 1; }

// Monotonic wall clock in ns.
uint64_t monotonic_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<uint64_t>(ts.tv_nsec);
}

// ns as a timespec.
timespec to_timespec(uint64_t ns) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(ns / 1000000000ull);
  ts.tv_nsec = static_cast<long>(ns % 1000000000ull);
  return ts;
}

// Sleeps until the monotonic clock reads wall_ns (returns early on a signal).
void sleep_until_ns(uint64_t wall_ns) {
  const timespec ts = to_timespec(wall_ns);
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

// Sleeps until the monotonic clock reads wall_ns, or until wake_fd (when >= 0) has bytes to read,
// or a signal comes. A wake_fd that reports a hang-up (a pty master with no slave open; PtyLink
// holds one open, so this is a safeguard) would end every wait at once: the rest is slept instead.
void wait_until_ns(uint64_t wall_ns, int wake_fd) {
  if (wake_fd >= 0) {
    const uint64_t now_ns = monotonic_ns();
    if (now_ns >= wall_ns) return;
    const timespec timeout = to_timespec(wall_ns - now_ns);
    pollfd wake = {wake_fd, POLLIN, 0};
    const int ready = ppoll(&wake, 1, &timeout, nullptr);
    const bool hung_up = ready == 1 && !(wake.revents & POLLIN) && (wake.revents & (POLLHUP | POLLERR | POLLNVAL));
    if (!hung_up) return;  // the time came, host bytes wait, or a signal
  }
  sleep_until_ns(wall_ns);
}

// Default firmware path: <dir of this binary>/../firmware/stepchoir-<board>.elf.
std::string default_elf_path(const std::string &board) {
  char exe[PATH_MAX];
  const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
  std::string dir = ".";
  if (len > 0) {
    exe[len] = '\0';
    dir = exe;
    const size_t slash = dir.rfind('/');
    dir = slash == std::string::npos ? "." : dir.substr(0, slash);
  }
  return dir + "/../firmware/stepchoir-" + board + ".elf";
}

// clock_ppm as the trace header shows it (integer when whole).
std::string ppm_text(double clock_ppm) {
  char text[64];
  if (clock_ppm == std::floor(clock_ppm))
    std::snprintf(text, sizeof text, "%.0f", clock_ppm);
  else
    std::snprintf(text, sizeof text, "%g", clock_ppm);
  return text;
}

// Keeps stdout for the pty line only: stray library prints go to stderr. Returns the real stdout.
FILE *reserve_stdout() {
  std::fflush(stdout);
  const int real_stdout_fd = dup(STDOUT_FILENO);
  dup2(STDERR_FILENO, STDOUT_FILENO);
  FILE *real_stdout = real_stdout_fd >= 0 ? fdopen(real_stdout_fd, "w") : nullptr;
  return real_stdout;
}

// Installs the stop signals; ignores SIGPIPE.
void install_signals() {
  struct sigaction action;
  std::memset(&action, 0, sizeof action);
  action.sa_handler = &on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGHUP, &action, nullptr);
  action.sa_handler = &on_reset_signal;
  sigaction(SIGUSR1, &action, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

// How the simulation loop ended.
struct LoopResult {
  CoreState state = CoreState::kRunning;
  uint64_t wall_ns = 0;  // wall time the loop ran
  uint64_t lag_max_ns = 0;
  uint64_t lag_max_cycle = 0;
  uint64_t slipped_ns = 0;
  uint64_t host_resets = 0;  // resets by the host's open of the pty
};

// Board cycles in ms of its time.
uint64_t ms_to_cycles(double ms, const BoardConfig &board) { return static_cast<uint64_t>(ms * board.f_cpu_hz / 1000); }

// The simulation loop: chunks of up to kChunkUs simulated time (a chunk ends early where the
// USB bridge passes board bytes to the host); between chunks the pty is polled and
// flushed, the trace written out now and then, and (when pacing) the loop sleeps while ahead
// until the wall clock catches up or the host writes.
LoopResult simulate(const Options &options, const BoardConfig &board, AvrAdapter &avr, PtyLink &link,
                    TraceWriter &trace) {
  prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);  // 1 us sleep precision instead of 50 us
  const uint64_t chunk_cycles = board.f_cpu_hz / 1000000 * kChunkUs;
  const uint64_t end_cycle =
      options.seconds > 0 ? static_cast<uint64_t>(std::llround(options.seconds * board.f_cpu_hz)) : UINT64_MAX;
  Pacer pacer(board.f_cpu_hz * options.speed, options.clock_ppm, kMaxCatchupNs);
  avr.set_pacer(&pacer);
  const uint64_t start_wall_ns = monotonic_ns();
  pacer.start(avr.cycle(), start_wall_ns);
  // Where the board's cycles stand on the machine's monotonic clock, so that the traces of
  // several boards (their own crystals) can be laid on one time line.
  trace.comment("wall_start cycle=" + std::to_string(avr.cycle()) + " monotonic_ns=" + std::to_string(start_wall_ns));
  avr.set_end_cycle(end_cycle);
  uint64_t last_trace_flush_ns = start_wall_ns;
  uint64_t wall_ns = start_wall_ns;  // the wall clock at the last chunk's end or wait's end
  LoopResult result;

  const pid_t parent = getppid();
  uint64_t chunk = 0;
  while (!g_stop_signal && avr.cycle() < end_cycle) {
    // Once a millisecond (system calls: every chunk would cost the simulation a fifth of its
    // speed): a board started by a program (stepchoir play, render) goes when it goes, even
    // killed; the host's open of the pty resets the board, and so does SIGUSR1 (its button).
    const bool check = ++chunk % kCheckChunks == 0;
    if (check && options.exit_with_parent && getppid() != parent) g_stop_signal = SIGHUP;
    const auto reset = [&] {
      avr.reset_by_host(options.bootloader ? ms_to_cycles(board.bootloader_ms, board) : 0);
      trace.mcu_reset(avr.cycle());
    };
    if (check && link.take_host_open() && options.auto_reset) {
      reset();
      ++result.host_resets;
    }
    if (check && g_reset_button) {
      g_reset_button = 0;
      reset();
    }
    avr.leave_bootloader_when_done();
    // Host bytes are stamped, when pacing, with the simulated time of their arrival on the wall
    // clock (read as they are): the USB frame the real bridge would put them in; else with the
    // simulation's now. The adapter hands each to the UART on its bridge cycle, and ends a
    // chunk early where the bridge passes the board's bytes to the host.
    link.poll_rx(options.pacing ? host_arrival_ns(pacer, monotonic_ns()) : link.now_ns());
    avr.kick_rx();
    const uint64_t left_cycles = end_cycle - avr.cycle();
    const uint64_t stop_cycle = left_cycles > chunk_cycles ? avr.cycle() + chunk_cycles : end_cycle;
    result.state = avr.run_until(stop_cycle);
    link.set_now_ns(pacer.sim_ns(avr.cycle()));
    const size_t passed = link.flush_tx();
    if (passed && options.trace_frames) trace.reply(avr.cycle(), passed);
    avr.maintain();
    if (result.state != CoreState::kRunning) break;
    wall_ns = monotonic_ns();
    if (wall_ns - last_trace_flush_ns >= kTraceFlushNs) {
      trace.flush();
      last_trace_flush_ns = wall_ns;
    }
    if (options.pacing && pacer.ahead_ns(avr.cycle(), wall_ns) > kAheadBeforeSleepNs) {
      wait_until_ns(pacer.due_wall_ns(avr.cycle()), link.rx_wake_fd());
      wall_ns = monotonic_ns();
    }
  }
  link.flush_tx();
  result.wall_ns = monotonic_ns() - start_wall_ns;
  result.lag_max_ns = pacer.lag_max_ns();
  result.lag_max_cycle = pacer.lag_max_cycle();
  result.slipped_ns = pacer.slipped_ns();
  return result;
}

// Collects the run-level numbers for the summary.
RunFacts gather_facts(const Options &options, const BoardConfig &board, const AvrAdapter &avr,
                      const PtyLink &link, const LineNoise &noise, const LoopResult &result) {
  RunFacts facts;
  facts.end_reason = result.state == CoreState::kCrashed ? "crashed"
                     : result.state == CoreState::kDone  ? "done"
                     : g_stop_signal                     ? "signal"
                                                         : "seconds";
  facts.end_cycle = avr.cycle();
  facts.f_cpu_hz = board.f_cpu_hz;
  facts.vector_count = board.vector_count;
  facts.vector_size_bytes = avr.vector_size_bytes();
  facts.pacing = options.pacing;
  facts.clock_ppm = options.clock_ppm;
  facts.wall_seconds = static_cast<double>(result.wall_ns) / 1e9;
  facts.lag_max_ns = result.lag_max_ns;
  facts.lag_max_cycle = result.lag_max_cycle;
  facts.slipped_ns = result.slipped_ns;
  facts.uart_in_bytes = avr.uart_in_bytes();
  facts.uart_in_lost = avr.uart_in_lost();
  facts.uart_xoff_count = avr.uart_xoff_count();
  facts.uart_would_overrun = avr.uart_would_overrun();
  facts.uart_out_bytes = avr.uart_out_bytes();
  facts.uart_dropped = link.tx_dropped();
  facts.host_bytes = link.rx_bytes();
  facts.link_model = link_model_name(link.bridge().model());
  facts.host_resets = result.host_resets;
  facts.line_dropped = noise.dropped();
  facts.line_corrupted = noise.corrupted();
  facts.line_duplicated = noise.duplicated();
  return facts;
}

// Trace header line, CSV header and "#" lines describing the setup and the state at cycle 0.
void write_trace_preamble(const Options &options, const BoardConfig &board, const std::string &elf_path,
                          const VirtualBoard &model, TraceWriter &trace) {
  trace.header(board.cli_name, board.f_cpu_hz, ppm_text(options.clock_ppm),
               static_cast<unsigned>(board.motors.size()), options.travel_steps);
  trace.comment("elf=" + elf_path + " switch_active=" + (options.switch_active_low ? "low" : "high") +
                " chatter_us=" + std::to_string(options.chatter_us) +
                " start_position=" + std::to_string(options.start_position_steps) +
                " seed=" + std::to_string(options.seed) + " wake_us=" + std::to_string(options.wake_us));
  for (const std::string &line : model.initial_lines()) trace.comment(line);
}

// The USB bridge of --link-model, its USB frames and timer at phases drawn from --seed (a real
// bridge's clock starts at no particular moment), and its draws seeded from it.
UsbBridge make_bridge(const Options &options) {
  LinkModel model = LinkModel::kIdeal;
  parse_link_model(options.link_model, model);
  const BridgeTiming timing = link_model_timing(model, options.ftdi_latency_ms);
  std::mt19937_64 rng(options.seed ^ 0x5eedb41d6eull);
  const uint64_t frame_phase = timing.usb_frame_ns ? rng() % timing.usb_frame_ns : 0;
  const uint64_t flush_phase = timing.flush_period_ns ? rng() % timing.flush_period_ns : 0;
  return UsbBridge(model, timing, frame_phase, flush_phase, rng());
}

// Everything one run needs, in construction order. real_stdout receives the pty line only.
int run(const Options &options, FILE *real_stdout) {
  BoardConfig board;
  board_config_for(options.board, board);
  std::string error;
  for (const bool sleep : {true, false})
    for (const Options::MotorPin &mp : sleep ? options.sleep_pins : options.reset_pins)
      if (!wire_driver_pin(board, mp.motor, mp.arduino, sleep, error)) {
        std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
        return 1;
      }
  const std::string elf_path = options.elf_path.empty() ? default_elf_path(options.board) : options.elf_path;
  if (access(elf_path.c_str(), R_OK) != 0) {
    std::fprintf(stderr, "stepchoir-vboard: firmware %s: %s\n", elf_path.c_str(), std::strerror(errno));
    return 1;
  }

  TraceWriter trace;
  if (!options.trace_path.empty() && !trace.open(options.trace_path, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }
  CodeSymbols symbols;
  if (!symbols.load(elf_path, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }

  ModelSettings settings;
  settings.travel_steps = options.travel_steps;
  settings.start_position_steps = options.start_position_steps;
  settings.switch_active_low = options.switch_active_low;
  settings.chatter_cycles = options.chatter_us * (board.f_cpu_hz / 1000000);
  settings.stuck_switch_motor = options.stuck_switch_motor;
  settings.dead_switch_motor = options.dead_switch_motor;
  settings.seed = options.seed;
  settings.wake_cycles = options.wake_us * (board.f_cpu_hz / 1000000);
  VirtualBoard model(board, settings, trace);
  model.settle_initial_switches();

  PtyLink link;
  if (!link.open(error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }
  link.set_bridge(make_bridge(options));
  AvrAdapter avr(board, model, link);
  avr.set_rx_gap_cycles(link.bridge().timing().host_byte_ns * board.f_cpu_hz / 1000000000ull);
  model.set_driver(&avr);
  LineNoiseRates rates;
  rates.drop = options.line_drop;
  rates.corrupt = options.line_corrupt;
  rates.duplicate = options.line_duplicate;
  LineNoise noise(rates, options.seed);
  avr.set_line_noise(&noise);
  if (options.trace_frames) avr.set_frame_trace(&trace);
  if (!avr.load(elf_path, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }
  if (!options.eeprom_path.empty() && !avr.load_eeprom(options.eeprom_path, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }
  avr.set_bootloader_quiet(ms_to_cycles(board.bootloader_quiet_ms, board));
  if (options.bootloader && board.bootloader_at_power_on) avr.hold_in_bootloader(ms_to_cycles(board.bootloader_ms, board));
  std::unique_ptr<CpuProfiler> profiler;
  if (options.measure) {
    profiler.reset(new CpuProfiler(avr.flash_bytes(), board.vector_count, avr.vector_size_bytes(),
                                   symbols.isr_ranges()));
    avr.set_profiler(profiler.get());
  }
  if (!options.link_path.empty() && !link.make_link(options.link_path, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
    return 1;
  }

  write_trace_preamble(options, board, elf_path, model, trace);

  if (real_stdout) {
    std::fprintf(real_stdout, "pty: %s\n", link.slave_path().c_str());
    std::fflush(real_stdout);
  }
  const LoopResult result = simulate(options, board, avr, link, trace);

  if (profiler) profiler->finish(avr.cycle(), avr.interrupts_enabled());
  if (!options.eeprom_path.empty() && !avr.save_eeprom(options.eeprom_path, error))
    std::fprintf(stderr, "stepchoir-vboard: %s\n", error.c_str());
  const RunFacts facts = gather_facts(options, board, avr, link, noise, result);
  const std::vector<std::string> summary = summary_lines(facts, model, profiler.get(), symbols);
  trace.comment("end cycle=" + std::to_string(facts.end_cycle));
  for (const std::string &line : summary) trace.comment("summary " + line);
  trace.close();
  if (!options.quiet)
    for (const std::string &line : summary) std::fprintf(stderr, "stepchoir-vboard: %s\n", line.c_str());
  // Said even with --quiet: a test labelled `pacing` that fails shows it (ctest prints the
  // test's output), so a stalled machine is told apart from a firmware fault.
  if (options.pacing && (facts.slipped_ns > 0 || facts.lag_max_ns > kStallWarnNs))
    std::fprintf(stderr,
                 "stepchoir-vboard: the machine stalled the simulation: it fell up to %.1f ms behind real time "
                 "(%.1f ms given up); timing judged in real time on this run measures the machine\n",
                 static_cast<double>(facts.lag_max_ns) / 1e6, static_cast<double>(facts.slipped_ns) / 1e6);
  link.remove_link();

  const CoreState state = result.state;
  if (state == CoreState::kCrashed || state == CoreState::kDone) {
    std::fprintf(stderr, "stepchoir-vboard: the AVR %s at cycle %llu (simavr state %s)\n",
                 state == CoreState::kCrashed ? "crashed" : "stopped (sleep with interrupts off)",
                 static_cast<unsigned long long>(facts.end_cycle),
                 state == CoreState::kCrashed ? "cpu_Crashed" : "cpu_Done");
    return 2;
  }
  return 0;
}

}  // namespace

// Parses the command line and runs the board.
int main(int argc, char **argv) {
  vboard::Options options;
  std::string error;
  if (!vboard::parse_options(argc, argv, options, error)) {
    std::fprintf(stderr, "stepchoir-vboard: %s\n%s", error.c_str(), vboard::usage_text());
    return 1;
  }
  if (options.help) {
    std::fputs(vboard::usage_text(), stdout);
    return 0;
  }
  FILE *real_stdout = reserve_stdout();  // before simavr can print anything
  install_signals();
  vboard::AvrAdapter::install_logger(options.quiet);
  return run(options, real_stdout);
}

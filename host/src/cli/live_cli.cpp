// live_cli.cpp: `stepchoir live`: opens the boards (or starts the virtual board), the MIDI
// input and a LiveSession; shows one status line; silences everything on the way out.
#include "cli/live_cli.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <spdlog/async.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "board/board.h"
#include "board/vboard_child.h"
#include "cli/learn_prompt.h"
#include "cli/setlist_runner.h"
#include "config/config.h"
#include "config/rig.h"
#include "live/realtime_setup.h"
#include "live/midi_in.h"
#include "live/session.h"

extern char **environ;

namespace stepchoir {
namespace {

// Called from: the status line. "C4", "F#5" for a MIDI note.
std::string note_name(int note) {
  static const char *const kNames[12] = {"C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"};
  return std::string(kNames[note % 12]) + std::to_string(note / 12 - 1);
}

// Called from: run_live, every 100 ms. The one status line: motors, link, latency.
std::string status_line(const LiveSession &s, const std::vector<std::unique_ptr<Board>> &boards) {
  std::string line;
  for (size_t m = 0; m < s.motor_count(); ++m) {
    const int note = s.motor_note(m);
    line += "m" + std::to_string(m) + " " + (note < 0 ? std::string("--") : note_name(note)) + "  ";
  }
  const uint64_t now = monotonic_us();
  for (size_t b = 0; b < s.board_count(); ++b) {
    const BoardStats &st = s.board_stats(b);
    const uint64_t seen = st.last_status_us.load();
    const char *health = st.write_failed ? "WRITE FAILED"
                         : st.read_failed ? "READ FAILED"
                         : (seen && now - seen < 2500000) ? (st.watchdog_tripped ? "watchdog" : "ok")
                                                          : "no answer";
    line += "| " + (boards[b] ? boards[b]->link().name() : std::string("?")) + " " + health + ", " + std::to_string(st.frames_sent.load()) +
            " frames, " + std::to_string(st.status_frames_bad.load()) + " bad ";
  }
  char lat[96];
  std::snprintf(lat, sizeof lat, "| %llu events, latency p50 %llu us p99 %llu us",
                static_cast<unsigned long long>(s.events()), static_cast<unsigned long long>(s.latency().percentile(0.5)),
                static_cast<unsigned long long>(s.latency().percentile(0.99)));
  return line + lat;
}

// Called from: run_live's loop when board b's link failed. Parks the board's threads, then
// reopens `path` every 500 ms until a board with as many motors is greeted (or *stop), and
// configures its motors again from `settings` (the open reset it: it runs on defaults); the
// session then restores what should be sounding. Says so on stdout.
void reconnect(LiveSession &session, size_t b, const std::string &path, size_t motors, const BoardSettings *settings,
               std::vector<std::unique_ptr<Board>> &boards, const std::atomic<bool> &stop, spdlog::logger &log) {
  std::printf("\nlive: %s: link lost; reconnecting\n", path.c_str());
  std::fflush(stdout);
  // The old link may be closed only once the board's threads no longer touch it (a serial
  // write can block for a second).
  while (!session.detach_link(b)) {
    log.warn("{}: the board's threads are still using the lost link; waiting", path);
    if (stop.load()) return;
  }
  boards[b].reset();
  while (!stop.load()) {
    try {
      auto board = std::make_unique<Board>(open_link(path));
      const Caps caps = board->greet(Board::kBootWaitMs, 600);
      if (caps.motor_count != motors)
        throw std::runtime_error("it has " + std::to_string(caps.motor_count) + " motors, not " + std::to_string(motors));
      if (settings) configure_motors(*board, caps, *settings, path);
      session.attach_link(b, &board->link());
      boards[b] = std::move(board);
      std::printf("live: %s: reconnected\n", path.c_str());
      std::fflush(stdout);
      return;
    } catch (const std::exception &e) {
      log.debug("{}: {}", path, e.what());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

// Called from: run_live's loop, once a second. When the MIDI input went away: closes it,
// releases every note (reset-all-controllers and all-sound-off on every channel: no note-off
// or pedal release will come for what was down) and says so; while it is away, reopens it as soon as the selector finds a port.
void watch_midi_input(std::unique_ptr<MidiIn> &midi, MidiApi api, const std::string &selector, LiveSession &session,
                      bool tty) {
  if (midi && midi->still_there()) return;
  if (midi) {
    const std::string name = midi->port_name();
    midi.reset();  // its callback has ended: this thread is now the queue's only producer
    for (uint8_t ch = 0; ch < 16; ++ch)
      for (uint8_t cc : {kCcResetAllControllers, kCcAllSoundOff})  // pedals up, bends centred, silence
        while (!session.midi_queue().try_enqueue(control_change(ch, cc, 0, monotonic_us())))
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::printf("%slive: MIDI input %s is gone; every note released, waiting for it\n", tty ? "\n" : "",
                name.c_str());
    std::fflush(stdout);
    return;
  }
  try {
    midi = std::make_unique<MidiIn>(api, selector, session.midi_queue());
    std::printf("%slive: MIDI input %s is back\n", tty ? "\n" : "", midi->port_name().c_str());
    std::fflush(stdout);
  } catch (const std::exception &) {
  }
}

}  // namespace

void print_midi_inputs(const std::string &midi_api) {
  try {
    const auto inputs = list_midi_inputs(parse_midi_api(midi_api));
    std::printf("MIDI inputs (%s):%s\n", midi_api.c_str(), inputs.empty() ? " none" : "");
    for (size_t i = 0; i < inputs.size(); ++i) std::printf("  %zu: %s\n", i, inputs[i].c_str());
  } catch (const std::exception &e) {
    std::printf("MIDI inputs (%s): unavailable: %s\n", midi_api.c_str(), e.what());
  }
}

int run_live(const LiveOptions &o, const std::atomic<bool> &stop) {
  spdlog::init_thread_pool(1024, 1);
  auto log = spdlog::create_async<spdlog::sinks::stderr_color_sink_mt>("live");
  log->set_pattern("stepchoir live: %^%l%$: %v");
  // The file's settings, then the command line's over them.
  const Rig rig = load_rig(o.config);
  const LiveConfig &cfg = rig.config;
  const std::string midi_selector = o.midi.empty() ? cfg.midi_input : o.midi;
  const std::string api_name = o.midi_api.empty() ? cfg.midi_api : o.midi_api;
  const MidiApi api = parse_midi_api(api_name);
  const Policy policy = o.policy.empty() ? cfg.policy : parse_policy(o.policy);
  std::vector<std::string> ports = o.ports;
  if (ports.empty())
    for (const BoardSettings &b : cfg.boards)
      if (!b.port.empty()) ports.push_back(b.port);

  std::unique_ptr<VirtualBoard> vboard;
  if (ports.empty()) {
    const std::string link = "/tmp/stepchoir-live-" + std::to_string(::getpid()) + ".pty";
    vboard = std::make_unique<VirtualBoard>(o.vboard_board, link, o.vboard_trace, std::vector<std::string>{});
    std::printf("live: no --port: playing on the virtual board (%s, bundled firmware) at %s\n",
                o.vboard_board.c_str(), link.c_str());
    ports.push_back(link);
  }
  std::vector<std::unique_ptr<Board>> boards;
  std::vector<LiveBoard> pool;
  std::vector<SetlistBoard> setlist_boards;
  for (size_t b = 0; b < ports.size(); ++b) {
    boards.push_back(std::make_unique<Board>(open_link(ports[b])));
    const Caps caps = vboard ? boards.back()->hello() : boards.back()->greet();  // its own board does not reset
    const BoardSettings *settings = board_settings(rig, ports[b], b);
    if (settings) configure_motors(*boards.back(), caps, *settings, ports[b]);
    if (cfg.home_on_start) home_board(*boards.back(), caps, settings, ports[b], {}, say_line);
    pool.push_back(LiveBoard{&boards.back()->link(), caps.motor_count, caps.f_cpu_hz});
    setlist_boards.push_back(SetlistBoard{ports[b], caps, settings});
  }
  AllocatorConfig alloc = pool_config(pool, policy);
  apply_allocation(cfg, &alloc);
  for (size_t b = 0, first = 0; b < pool.size(); first += pool[b].motor_count, ++b) {
    const BoardSettings *settings = board_settings(rig, ports[b], b);
    for (size_t m = 0; settings && m < settings->motors.size() && m < pool[b].motor_count; ++m) {
      const uint32_t f_cpu_hz = alloc.motors[first + m].f_cpu_hz;
      alloc.motors[first + m] = settings->motors[m].music;
      alloc.motors[first + m].f_cpu_hz = f_cpu_hz;
      alloc.mono_channel[first + m] = settings->motors[m].mono_channel;
    }
  }
  std::vector<LivePreset> presets = live_presets(cfg, alloc);  // every motor index checked against the pool
  const std::string locked = lock_memory();  // before the real-time threads start
  const std::vector<Binding> controls = live_controls(cfg, alloc.motor_count);
  std::unique_ptr<LearnPrompt> learn;
  if (o.learn) {
    const std::string path = rig.path.empty() ? default_config_path() : rig.path;
    if (path.empty()) throw std::runtime_error("--learn: no rig file to save to (give --config FILE, or set HOME)");
    learn = std::make_unique<LearnPrompt>(path, alloc.motor_count);
  }
  std::unique_ptr<SetlistRunner> setlist;
  if (!cfg.setlist.empty()) setlist = std::make_unique<SetlistRunner>(cfg.setlist, setlist_boards, cfg.a4_hz);
  LiveSession session(pool, alloc);
  session.set_presets(std::move(presets));
  for (const Binding &b : controls) session.bind(b);
  for (size_t b = 0; setlist && setlist->has_songs() && b < pool.size(); ++b) session.forward_replies(b);
  auto midi = std::make_unique<MidiIn>(api, midi_selector, session.midi_queue());
  session.start();
  const char *policy_names[] = {"poly", "channel", "mono"};
  std::printf("live: MIDI %s (%s) -> %zu motors, policy %s; Ctrl-C to stop\n", midi->port_name().c_str(),
              api_name.c_str(), session.motor_count(), policy_names[static_cast<int>(policy)]);
  std::fflush(stdout);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const size_t rt_wanted = 1 + session.board_count();  // the engine and a writer a board
  std::printf("live: real time: %s; %d of %zu threads SCHED_FIFO%s\n",
              locked.empty() ? "memory locked" : locked.c_str(), session.realtime_threads(), rt_wanted,
              size_t(session.realtime_threads()) == rt_wanted ? "" : " (`stepchoir doctor` says how to allow it)");
  std::fflush(stdout);

  uint64_t errors_logged = 0, dropped_logged = 0;
  int preset_shown = -1;
  const bool tty = ::isatty(1);
  auto last_print = std::chrono::steady_clock::now();
  for (unsigned tick = 1; !stop.load(); ++tick) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (tick % 10 == 0) watch_midi_input(midi, api, midi_selector, session, tty);
    if (learn) learn->poll(session);
    if (setlist) setlist->poll(session);
    uint64_t errors = 0;
    for (size_t b = 0; b < session.board_count(); ++b) {
      errors += session.board_stats(b).board_errors.load();
      const BoardStats &st = session.board_stats(b);
      if (st.write_failed.load() || st.read_failed.load()) 
        reconnect(session, b, ports[b], pool[b].motor_count, board_settings(rig, ports[b], b), boards, stop, *log);
    }
    if (errors != errors_logged) {
      log->warn("the boards reported {} errors (latest: {})", errors,
                sc::error_name(session.board_stats(0).last_error.load()));
      errors_logged = errors;
    }
    if (midi && midi->dropped() != dropped_logged) {
      dropped_logged = midi->dropped();
      log->warn("{} MIDI events dropped: the engine fell behind", dropped_logged);
    }
    if (session.preset() != preset_shown) {
      preset_shown = session.preset();
      const LivePreset &p = session.presets()[static_cast<size_t>(preset_shown)];
      std::printf("%slive: preset %d %s\n", tty && !o.quiet ? "\n" : "", p.program + 1, p.name.c_str());
      std::fflush(stdout);
    }
    if (o.quiet) continue;
    const auto now = std::chrono::steady_clock::now();
    if (tty) {
      std::printf("\r%s\033[K", status_line(session, boards).c_str());
      std::fflush(stdout);
    } else if (now - last_print >= std::chrono::seconds(1)) {
      std::printf("%s\n", status_line(session, boards).c_str());
      std::fflush(stdout);
      last_print = now;
    }
  }
  midi.reset();  // no more callbacks
  if (setlist) setlist->stop(session);
  session.stop();
  if (tty && !o.quiet) std::printf("\n");
  std::printf("live: every motor silenced (%llu events, latency p50 %llu us, p99 %llu us, max %llu us)\n",
              static_cast<unsigned long long>(session.events()),
              static_cast<unsigned long long>(session.latency().percentile(0.5)),
              static_cast<unsigned long long>(session.latency().percentile(0.99)),
              static_cast<unsigned long long>(session.latency().max_us()));
  std::fflush(stdout);
  spdlog::shutdown();
  return 0;
}

}  // namespace stepchoir

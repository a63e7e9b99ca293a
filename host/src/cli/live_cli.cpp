// live_cli.cpp: `stepchoir live`: opens the boards (or starts the virtual board), the MIDI
// input and a LiveSession; runs the main loop (the console or the status line, link repair,
// the MIDI input's watch); silences everything on the way out.
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
#include "cli/console.h"
#include "cli/console_model.h"
#include "cli/learn_prompt.h"
#include "cli/link_repair.h"
#include "cli/setlist_runner.h"
#include "config/board_memory.h"
#include "config/config.h"
#include "config/rig.h"
#include "live/realtime_setup.h"
#include "live/midi_in.h"
#include "live/session.h"

extern char **environ;

namespace stepchoir {
namespace {

// Where live's messages go: the console's messages while it is up, else a line on stdout
// (after a newline when the status line holds the terminal's last line).
struct Say {
  Console *console = nullptr;
  bool after_status = false;
  void operator()(const std::string &line) const {
    if (console) return console->notice(line);
    std::printf("%slive: %s\n", after_status ? "\n" : "", line.c_str());
    std::fflush(stdout);
  }
};

// Called from: run_live's loop, once a second. When the MIDI input went away: closes it,
// releases every note (reset-all-controllers and all-sound-off on every channel: no note-off
// or pedal release will come for what was down) and says so; while it is away, reopens it as soon as the selector finds a port.
void watch_midi_input(std::unique_ptr<MidiIn> &midi, MidiApi api, const std::string &selector, LiveSession &session,
                      const Say &say) {
  if (midi && midi->still_there()) return;
  if (midi) {
    const std::string name = midi->port_name();
    midi.reset();  // its callback has ended: this thread is now the queue's only producer
    for (uint8_t ch = 0; ch < 16; ++ch)
      for (uint8_t cc : {kCcResetAllControllers, kCcAllSoundOff})  // pedals up, bends centred, silence
        while (!session.midi_queue().try_enqueue(control_change(ch, cc, 0, monotonic_us())))
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
    say("MIDI input " + name + " is gone; every note released, waiting for it");
    return;
  }
  try {
    midi = std::make_unique<MidiIn>(api, selector, session.midi_queue());
    say("MIDI input " + midi->port_name() + " is back");
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
  std::vector<std::string> ports = rig_ports(rig, o.ports, !o.vboard_board.empty() || !o.vboard_trace.empty());

  // No port: the virtual boards of --vboard (one), else of the rig file (config/rig.h).
  std::vector<std::unique_ptr<VirtualBoard>> vboards;
  if (ports.empty()) {
    const std::vector<std::string> kinds =
        rig_vboards(rig, o.vboard_board.empty() ? std::vector<std::string>{} : std::vector<std::string>{o.vboard_board});
    for (size_t k = 0; k < kinds.size(); ++k) {
      const std::string link = vboard_link_path("live", k);
      vboards.push_back(std::make_unique<VirtualBoard>(kinds[k], link, vboard_trace_path(o.vboard_trace, k),
                                                       std::vector<std::string>{}));
      std::printf("live: no --port: playing on the virtual board (%s, bundled firmware) at %s\n", kinds[k].c_str(),
                  link.c_str());
      ports.push_back(link);
    }
  }
  std::vector<std::unique_ptr<Board>> boards;
  std::vector<LiveBoard> pool;
  std::vector<SetlistBoard> setlist_boards;
  for (size_t b = 0; b < ports.size(); ++b) {
    boards.push_back(std::make_unique<Board>(open_link(ports[b])));
    const Caps caps = vboards.empty() ? boards.back()->greet() : boards.back()->hello();  // its own do not reset
    const BoardSettings *settings = board_settings(rig, ports[b], b);
    if (settings) configure_motors(*boards.back(), caps, *settings, ports[b]);
    if (cfg.home_on_start) home_board(*boards.back(), caps, settings, ports[b], {}, say_line);
    // A board met before (config/board_memory.h): the keyboard plays in tune with its crystal,
    // and a setlist song starts from its remembered rate.
    std::optional<BoardRecord> known;
    std::optional<uint64_t> id;
    if (vboards.empty()) {
      if ((id = identify_board(*boards.back()))) {
        try {
          known = recall_board(*id);
        } catch (const std::exception &e) {
          log->warn("{} (the board memory is left aside)", e.what());
        }
        if (known) log->info("{} is board {}, met before: crystal {:+.1f} ppm", ports[b], board_id_hex(*id), known->clock_ppm);
      }
    }
    pool.push_back(LiveBoard{&boards.back()->link(), caps.motor_count, crystal_hz(caps.f_cpu_hz, known)});
    setlist_boards.push_back(SetlistBoard{ports[b], caps, settings, known, id});
  }
  AllocatorConfig alloc = pool_config(pool, policy);
  apply_allocation(cfg, &alloc);
  for (size_t b = 0, first = 0; b < pool.size(); first += pool[b].motor_count, ++b) {
    const BoardSettings *settings = board_settings(rig, ports[b], b);
    for (size_t m = 0; settings && m < settings->motors.size() && m < pool[b].motor_count; ++m) {
      const uint32_t f_cpu_hz = alloc.motors[first + m].f_cpu_hz;
      alloc.motors[first + m] = settings->motors[m].music;
      alloc.motors[first + m].f_cpu_hz = f_cpu_hz;
      alloc.mono_channel[first + m] = motor_mono_channel(settings, static_cast<uint8_t>(m));
    }
  }
  std::vector<LivePreset> presets = live_presets(cfg, alloc);  // every motor index checked against the pool
  const std::string locked = lock_memory();  // before the real-time threads start
  const std::vector<Binding> controls = live_controls(cfg, alloc.motor_count);
  const std::string learn_path = rig.path.empty() ? default_config_path() : rig.path;
  std::unique_ptr<LearnPrompt> learn;
  if (o.learn) {
    if (learn_path.empty()) throw std::runtime_error("--learn: no rig file to save to (give --config FILE, or set HOME)");
    learn = std::make_unique<LearnPrompt>(learn_path, alloc.motor_count);
  }
  LiveSession session(pool, alloc);
  // After the session: however this function leaves, the setlist's song players, which write
  // through the session, are stopped and joined before it goes.
  std::unique_ptr<SetlistRunner> setlist;
  if (!cfg.setlist.empty()) setlist = std::make_unique<SetlistRunner>(cfg.setlist, setlist_boards, cfg.a4_hz);
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

  // The console on a terminal; else the status line (unless --quiet).
  const bool tty = ::isatty(1);
  std::unique_ptr<Console> console;
  if (!o.quiet && !o.plain && !learn && tty && ::isatty(0)) {
    try {
      std::vector<size_t> numbers(session.motor_count());
      for (size_t m = 0; m < numbers.size(); ++m) numbers[m] = m;
      console = std::make_unique<Console>(learn_path, numbers);
    } catch (const std::exception &e) {
      std::printf("live: %s: the status line instead\n", e.what());
    }
  }
  const Say say{console.get(), tty && !o.quiet && !console};
  const auto note = [&log](const std::string &line) { log->debug("{}", line); };  // repair_link's detail
  if (setlist) setlist->set_say([&say](const std::string &line) { say(line); });
  ConsoleSources sources;
  sources.board_names = ports;
  sources.reconnecting.assign(ports.size(), false);
  for (size_t b = 0; b < ports.size(); ++b)
    for (uint8_t m = 0; m < pool[b].motor_count; ++m)
      sources.travel_steps.push_back(motor_travel(board_settings(rig, ports[b], b), m));
  sources.music = alloc;
  ConsoleSampler sampler;
  std::vector<LinkRepair> repairs(ports.size());
  uint64_t errors_logged = 0, dropped_logged = 0;
  int preset_shown = -1;
  auto last_print = std::chrono::steady_clock::now(), last_midi_check = last_print, last_draw = last_print;
  while (!stop.load()) {
    if (!console)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    else if (!console->handle_keys(session, Console::kFrameMs))
      break;  // q
    const auto now = std::chrono::steady_clock::now();
    if (now - last_midi_check >= std::chrono::seconds(1)) {
      watch_midi_input(midi, api, midi_selector, session, say);
      last_midi_check = now;
    }
    if (learn) learn->poll(session);
    if (setlist) setlist->poll(session);
    uint64_t errors = 0;
    for (size_t b = 0; b < session.board_count(); ++b) {
      errors += session.board_stats(b).board_errors.load();
      sources.reconnecting[b] = repair_link(session, b, ports[b], pool[b].motor_count, board_settings(rig, ports[b], b),
                                            boards, repairs[b], say, note);
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
      say("preset " + std::to_string(p.program + 1) + " " + p.name);
    }
    if (o.quiet) continue;
    if (setlist) {
      sources.setlist_item = static_cast<int>(setlist->position());
      sources.setlist_count = setlist->size();
      sources.setlist_name = setlist->item().name;
      sources.song_motors = setlist->song_motors();
    }
    sources.midi_input = midi ? midi->port_name() : "";
    sources.midi_dropped = midi ? midi->dropped() : 0;
    if (console) {
      if (now - last_draw >= std::chrono::milliseconds(Console::kFrameMs)) {
        console->draw(sampler.sample(session, sources, monotonic_us()));
        last_draw = now;
      }
    } else if (tty) {
      std::printf("\r%s\033[K", status_line(sampler.sample(session, sources, monotonic_us())).c_str());
      std::fflush(stdout);
    } else if (now - last_print >= std::chrono::seconds(1)) {
      std::printf("%s\n", status_line(sampler.sample(session, sources, monotonic_us())).c_str());
      std::fflush(stdout);
      last_print = now;
    }
  }
  console.reset();  // the terminal as it was, before anything else is printed
  midi.reset();  // no more callbacks
  if (setlist) setlist->stop(session);
  session.stop();
  if (say.after_status) std::printf("\n");
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

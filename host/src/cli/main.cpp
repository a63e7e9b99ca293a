// main.cpp: the `stepchoir` command: hello, tone, status, panic, driver, home, jog, center,
// ports, doctor, live, config, gcode, play, render, jam.
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <thread>

#include "board/board.h"
#include "board/link.h"
#include "board/vboard_child.h"
#include "cli/gcode_command.h"
#include "cli/doctor.h"
#include "cli/live_cli.h"
#include "cli/motion_command.h"
#include "cli/play_command.h"
#include "config/board_memory.h"
#include "config/config.h"
#include "config/rig.h"
#include "core/pitch.h"

namespace {

std::atomic<bool> g_stop{false};

// Called from: signal context. Only sets a flag.
void on_signal(int) { g_stop = true; }

// Called from: signal context (SIGUSR1). Pauses or resumes a running `play`.
void on_pause_signal(int) { stepchoir::toggle_play_pause(); }

// Prints a board's capabilities.
void print_caps(const stepchoir::Caps &c) {
  std::printf("board: %s\nprotocol: %u\nmotors: %u\nf_cpu_hz: %u\nqueue: %u\n", c.board_name.c_str(),
              c.protocol_version, c.motor_count, c.f_cpu_hz, c.queue_size);
  for (size_t m = 0; m < c.endstops.size(); ++m) {
    const uint8_t e = c.endstops[m];
    std::printf("motor %zu endstops: %s\n", m,
                e == 0 ? "none (soft limits)"
                       : (e & sc::kEndstopShared) ? "one switch for both ends"
                                                  : (e & sc::kEndstopMin && e & sc::kEndstopMax) ? "min and max"
                                                                                                   : (e & sc::kEndstopMin) ? "min" : "max");
  }
}

// Prints the board's id (a new board gets one) and the crystal error the host remembers of it.
void print_identity(stepchoir::Board &board) {
  const std::optional<uint64_t> id = stepchoir::identify_board(board);
  if (!id) {
    std::printf("id: none (the firmware keeps no id)\n");
    return;
  }
  std::printf("id: %s\n", stepchoir::board_id_hex(*id).c_str());
  try {
    if (const auto known = stepchoir::recall_board(*id))
      std::printf("crystal: %+.1f ppm (+/- %.1f), remembered in %s\n", known->clock_ppm, known->sigma_ppm,
                  stepchoir::board_memory_path().c_str());
    else
      std::printf("crystal: not measured yet (a song measures it)\n");
  } catch (const std::exception &e) {
    std::printf("crystal: %s\n", e.what());
  }
}

// Prints a status reply: the board's counters (reversals: every motor's), then a line a motor
// with its position, its own reversals at a switch or a soft limit, and its flags.
void print_status(const stepchoir::Status &s) {
  std::printf("frames_ok: %u\nframes_bad: %u\nuart_overruns: %u\nreversals: %u\nlate_edges: %u\n"
              "queue_used: %u\nlast_error: %u (%s)\nwatchdog_tripped: %s\ndrivers_enabled: %s\n",
              s.head.frames_ok, s.head.frames_bad, s.head.uart_overruns, s.head.reversals, s.head.late_edges,
              s.head.queue_used, s.head.last_error, sc::error_name(s.head.last_error),
              (s.head.flags & sc::kStatusWatchdogTripped) ? "yes" : "no",
              (s.head.flags & sc::kStatusDriversEnabled) ? "yes" : "no");
  for (size_t m = 0; m < s.motors.size(); ++m)
    std::printf("motor %zu: position %d reversals %u %s%s%s\n", m, s.motors[m].position_steps, s.motors[m].reversals,
                (s.motors[m].flags & sc::kMotorDirUp) ? "up" : "down",
                (s.motors[m].flags & sc::kMotorSounding) ? " sounding" : "",
                (s.motors[m].flags & sc::kMotorEndstopFault) ? " endstop-fault" : "");
}

// `stepchoir tone`: one motor at one frequency, heartbeats meanwhile, silence at the end.
int run_tone(stepchoir::Board &board, const stepchoir::Caps &caps, int motor, double hz, double seconds) {
  if (motor < 0 || motor >= caps.motor_count) {
    std::fprintf(stderr, "stepchoir tone: --motor %d: the board has motors 0-%d\n", motor, caps.motor_count - 1);
    return 2;
  }
  const uint32_t period = stepchoir::hz_to_period_q8(hz, caps.f_cpu_hz);
  if (hz > 0 && period == 0) {
    std::fprintf(stderr, "stepchoir tone: --hz %g is below the lowest playable frequency\n", hz);
    return 2;
  }
  // The board's watchdog may have been switched off by an earlier session: set it, so that the
  // note stops by itself if this program dies.
  board.send(stepchoir::watchdog_payload(sc::kWatchdogDefaultMs));
  board.send(stepchoir::periods_payload({{static_cast<uint8_t>(motor), period}}));
  try {
    if (auto r = board.wait_reply(sc::kMsgError, 30)) {
      std::fprintf(stderr, "stepchoir tone: the board refused the note: %s\n", sc::error_name((*r)[1]));
      return 1;
    }
    using clock = std::chrono::steady_clock;
    const auto end = clock::now() + std::chrono::duration_cast<clock::duration>(
                                        std::chrono::duration<double>(seconds > 0 ? seconds : 1e7));
    while (!g_stop && clock::now() < end && hz > 0) {
      board.send({sc::kMsgHeartbeat});
      const clock::duration left = end - clock::now();
      std::this_thread::sleep_for(std::min<clock::duration>(std::chrono::milliseconds(100), left));
    }
    if (hz > 0) board.send(stepchoir::periods_payload({{static_cast<uint8_t>(motor), sc::kPeriodSilent}}));
  } catch (...) {
    try {  // whatever went wrong, try to leave the motor silent (the watchdog is the backstop)
      board.send(stepchoir::periods_payload({{static_cast<uint8_t>(motor), sc::kPeriodSilent}}));
    } catch (...) {
    }
    throw;
  }
  return 0;
}

// `stepchoir driver`: one motor's driver woken, put to sleep, disabled or reset (kMsgDriverAct);
// main configured the motors from the rig file first (their SLEEP and RESET pins).
int run_driver(stepchoir::Board &board, const stepchoir::Caps &caps, const std::string &port, int motor,
               const std::string &action) {
  if (motor < 0 || motor >= caps.motor_count) {
    std::fprintf(stderr, "stepchoir driver: --motor %d: the board has motors 0-%d\n", motor, caps.motor_count - 1);
    return 2;
  }
  const char *const kActions[] = {"wake", "sleep", "disable", "reset"};
  const char *const kDone[] = {"awake", "asleep", "disabled", "reset"};
  uint8_t a = 0;
  while (action != kActions[a]) ++a;  // the parser allowed only these
  board.send(stepchoir::driver_act_payload(static_cast<uint8_t>(motor), a));
  if (auto r = board.wait_reply(sc::kMsgError, 100)) {
    std::fprintf(stderr, "stepchoir driver: the board refused %s: %s%s\n", action.c_str(), sc::error_name((*r)[1]),
                 (*r)[1] == sc::kErrConfig ? " (no SLEEP or RESET pin for that motor: --config with sleep_pin or "
                                             "reset_pin)"
                                           : "");
    return 1;
  }
  std::printf("%s: motor %d's driver %s\n", port.c_str(), motor, kDone[a]);
  return 0;
}

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"stepchoir: stepper motors that sing"};
  app.require_subcommand(1);
  // The one-board commands: the board at --port, else the rig file's first board; the rig
  // file's motor settings go to the board before anything else.
  std::string port, config_path;
  auto board_options = [&](CLI::App *c) {
    c->add_option("--port,-p", port, "Serial port or virtual-board link (default: the configuration's first board)");
    c->add_option("--config,-c", config_path,
                  "Rig configuration (default: " + stepchoir::default_config_path() + " if it exists)")
        ->check(CLI::ExistingFile);
  };
  auto *hello = app.add_subcommand("hello", "Print a board's capabilities");
  board_options(hello);
  auto *status = app.add_subcommand("status", "Print a board's counters and motor positions");
  board_options(status);
  auto *panic = app.add_subcommand("panic", "Silence every motor of a board now");
  board_options(panic);

  int motor = 0;
  double hz = 0, seconds = 0;
  auto *tone = app.add_subcommand("tone", "Play one motor at one frequency (0 Hz silences)");
  board_options(tone);
  tone->add_option("--motor,-m", motor, "Motor index")->default_val(0);
  tone->add_option("--hz", hz, "Frequency in Hz (steps per second)")->required()->check(CLI::Range(0.0, 40000.0));
  tone->add_option("--seconds,-s", seconds, "How long (default: until Ctrl-C)")->check(CLI::NonNegativeNumber);

  std::string driver_action;
  auto *driver = app.add_subcommand("driver", "Wake, sleep, disable or reset one motor's driver (the board's "
                                              "watchdog disables every driver 300 ms after the last frame)");
  board_options(driver);
  driver->add_option("--motor,-m", motor, "Motor index")->default_val(0);
  driver->add_option("action", driver_action, "wake, sleep, disable or reset")
      ->required()
      ->check(CLI::IsMember({"wake", "sleep", "disable", "reset"}));

  const stepchoir::MotionCommands motion = stepchoir::add_motion_commands(app, board_options);

  stepchoir::DoctorOptions doctor_opt;
  auto *doctor = app.add_subcommand("doctor", "Check the rig (configuration, serial permissions, real-time limits, MIDI, "
                                              "each board's firmware and round trip) and print the fix for each problem");
  doctor->add_option("--config,-c", doctor_opt.config,
                     "Rig configuration (default: " + stepchoir::default_config_path() + " if it exists)");
  doctor->add_option("--port,-p", doctor_opt.ports, "Board (repeatable; default: the file's boards, else every serial port)");

  std::string ports_midi_api = "alsa";
  auto *ports = app.add_subcommand("ports", "List serial ports and MIDI inputs");
  ports->add_option("--midi-api", ports_midi_api, "MIDI API whose inputs to list")->check(CLI::IsMember({"alsa", "jack"}));

  stepchoir::LiveOptions live_opt;
  auto *live = app.add_subcommand("live", "Play the motors from a MIDI input (Ctrl-C silences them and ends)");
  live->add_option("--config,-c", live_opt.config,
                   "Rig configuration (default: " + stepchoir::default_config_path() + " if it exists)")
      ->check(CLI::ExistingFile);
  live->add_option("--midi", live_opt.midi, "MIDI input: index, part of its name, or virtual[:NAME] (default virtual)");
  live->add_option("--port,-p", live_opt.ports, "Board (repeat for several: their motors form one pool); "
                                                "none: the file's boards, else the virtual board");
  live->add_option("--policy", live_opt.policy, "Note allocation (default poly)")
      ->check(CLI::IsMember({"poly", "channel", "mono"}));
  live->add_option("--midi-api", live_opt.midi_api, "MIDI API (default alsa)")->check(CLI::IsMember({"alsa", "jack"}));
  live->add_option("--vboard", live_opt.vboard_board,
                   "Board the virtual board simulates (without --port; default: the rig file's boards, else uno)")
      ->check(CLI::IsMember(stepchoir::kBoardKinds));
  live->add_option("--vboard-trace", live_opt.vboard_trace,
                   "Without --port: write the virtual board's trace here (stepchoir-render makes it a WAV)");
  live->add_flag("--quiet,-q", live_opt.quiet, "No console and no status line");
  live->add_flag("--plain", live_opt.plain, "The one status line, not the console, on a terminal");
  live->add_flag("--learn", live_opt.learn,
                 "MIDI learn: type an action, move a control; it is saved to the rig file's [[controls]]");

  auto *config = app.add_subcommand("config", "The rig configuration file every command reads");
  auto *print_default = config->add_flag("--print-default", "Print the commented default configuration");
  auto *where = config->add_flag("--where", "Print the file commands read without --config");
  std::string check_path;
  auto *check = config->add_option("--check", check_path,
                                   "Read a configuration file (default: the one commands read) and report the first "
                                   "problem")
                    ->expected(0, 1)
                    ->check(CLI::ExistingFile);
  config->require_option(1);
  const auto gcode = stepchoir::add_gcode_command(app);
  const auto play = stepchoir::add_play_commands(app);

  CLI11_PARSE(app, argc, argv);
  if (app.got_subcommand(gcode->app)) return gcode->run();
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  try {
    if (app.got_subcommand("ports")) {
      std::printf("serial ports:\n");
      for (const auto &p : stepchoir::list_serial_ports()) std::printf("  %s\n", p.c_str());
      stepchoir::print_midi_inputs(ports_midi_api);
      return 0;
    }
    if (app.got_subcommand(live)) return stepchoir::run_live(live_opt, g_stop);
    if (app.got_subcommand(doctor)) return stepchoir::run_doctor(doctor_opt);
    if (app.got_subcommand(play->play) || app.got_subcommand(play->render) || app.got_subcommand(play->jam)) {
      std::signal(SIGUSR1, on_pause_signal);
      return play->run(g_stop);
    }
    if (app.got_subcommand(config)) {
      if (*print_default) std::fputs(stepchoir::default_config_text(), stdout);
      if (*where) {
        const std::string path = stepchoir::default_config_path(), found = stepchoir::rig_path("");
        std::printf("%s%s\n", path.empty() ? "(no HOME: none)" : path.c_str(),
                    path.empty() ? "" : found.empty() ? " (not there: every setting at its default)" : "");
      }
      if (*check) {
        const std::string path = check_path.empty() ? stepchoir::rig_path("") : check_path;
        if (path.empty())
          throw std::runtime_error("config --check: no file given, and none at " + stepchoir::default_config_path());
        const auto c = stepchoir::load_config(path);
        std::printf("%s: ok (%zu boards)\n", path.c_str(), c.boards.size());
      }
      return 0;
    }
    const stepchoir::Rig rig = stepchoir::load_rig(config_path);
    port = stepchoir::rig_port(rig, port);
    if (port.empty())
      throw std::runtime_error("no --port, and " +
                               (rig.path.empty() ? "no configuration file (" + stepchoir::default_config_path() + ")"
                                                 : rig.path + " names no board port" +
                                                       (rig.config.boards.empty()
                                                            ? std::string()
                                                            : " (its boards are virtual: live, play, jam and render "
                                                              "start them; this command needs a port)")));
    stepchoir::Board board(stepchoir::open_link(port));
    if (app.got_subcommand(panic)) {
      // At once: a board that the open did not reset stops now. One that it reset is silent in
      // its bootloader, which gets nothing more (a Mega's stays in it while bytes come): its
      // capabilities are waited for, then silence is checked.
      board.resync();
      board.send({sc::kMsgStopAll});
      std::optional<stepchoir::Status> s = board.status(300);
      if (!s) board.greet();
      for (int attempt = 0;; ++attempt) {
        bool silent = s && !(s->head.flags & sc::kStatusDriversEnabled);
        if (s)
          for (const auto &m : s->motors) silent = silent && !(m.flags & sc::kMotorSounding);
        if (silent) break;
        if (attempt == 3) throw std::runtime_error(port + ": stop-all sent, but the board does not report silence");
        board.send({sc::kMsgStopAll});
        s = board.status(500);
      }
      std::printf("%s: every motor silent, drivers off\n", port.c_str());
      return 0;
    }
    const stepchoir::Caps caps = board.greet();  // waits out a reset by the open (DTR)
    // Before a motor moves, the rig's settings (a TB6600's pulse, SLEEP and RESET pins).
    const stepchoir::BoardSettings *settings = stepchoir::board_settings(rig, port, 0);
    if (settings && (app.got_subcommand(tone) || app.got_subcommand(driver) || motion.parsed()))
      stepchoir::configure_motors(board, caps, *settings, port);
    if (motion.parsed()) return motion.run(board, caps, settings, port);
    if (app.got_subcommand(hello)) {
      print_caps(caps);
      print_identity(board);
    } else if (app.got_subcommand(status)) {
      auto s = board.status(1000);
      if (!s) throw std::runtime_error(port + ": no status reply");
      print_status(*s);
    } else if (app.got_subcommand(tone)) {
      return run_tone(board, caps, motor, hz, seconds);
    } else if (app.got_subcommand(driver)) {
      return run_driver(board, caps, port, motor, driver_action);
    }
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir: %s\n", e.what());
    return 1;
  }
  return 0;
}

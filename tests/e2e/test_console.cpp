// test_console.cpp: the live console end to end, under tmux: `stepchoir live` in a detached
// tmux session of 80x24 (a terminal of its own, as over ssh), a JACK keyboard, the real
// firmware on an Uno virtual board. Read from the screen (capture-pane): the carriages in the
// middle of their rails, a key's motor row with its note and Hz, the octave key's transpose,
// the panic's message, the terminal given back after q. Read from the trace's STEP edges: the note after the octave key sounds an
// octave up, and the panic key silences every motor at once while the keys are still down.
// `stepchoir play` on a virtual board's pty: a song motor's note and Hz, paused on space, q.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "core/midi_event.h"
#include "e2e_more.h"
#include "live_rig.h"
#include "trace.h"

namespace tr = sc::trace;

namespace {

void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// A private tmux server (its own socket, no user configuration, no status bar) with one
// detached session of cols x rows running `command`; killed with everything in it at the end.
class TmuxSession {
 public:
  TmuxSession(const std::string &command, int cols, int rows)
      : socket_("stepchoir-e2e-" + std::to_string(::getpid())), conf_(e2e::scratch("tmux.conf")) {
    std::ofstream(conf_) << "set -g status off\n";
    tmux({"-f", conf_, "new-session", "-d", "-s", "console", "-x", std::to_string(cols), "-y", std::to_string(rows),
          command});
  }
  ~TmuxSession() {
    try {
      tmux({"kill-server"});
    } catch (const std::exception &) {
    }
  }
  TmuxSession(const TmuxSession &) = delete;
  TmuxSession &operator=(const TmuxSession &) = delete;

  // The pane's screen, a line a row (wrapped lines joined).
  std::string screen() { return tmux({"capture-pane", "-p", "-J", "-t", "console"}); }
  // Types a key (tmux's names: "Space", "Escape", "q").
  double key(const std::string &k) {
    tmux({"send-keys", "-t", "console", k});
    return Sender::now_s();
  }
  // A format of the pane: "#{alternate_on}", "#{cursor_flag}".
  std::string format(const std::string &f) { return tmux({"display-message", "-p", "-t", "console", f}); }
  // Waits up to 20 s for a screen that `shows`; that screen (the last one on failure).
  template <class F>
  std::string wait_until(F shows) {
    std::string s;
    for (int i = 0; i < 200; ++i) {
      s = screen();
      if (shows(s)) break;
      wait_ms(100);
    }
    return s;
  }
  std::string wait_for(const std::string &text) {
    return wait_until([&](const std::string &s) { return s.find(text) != std::string::npos; });
  }

 private:
  std::string tmux(std::vector<std::string> args) {
    args.insert(args.begin(), {"/usr/bin/tmux", "-L", socket_});
    stepchoir::ChildProcess p(args, true);
    std::string out, line;
    while (p.read_line(&line, 5000)) out += line + "\n";
    if (p.wait() != 0) throw std::runtime_error("tmux " + args[3] + " failed");
    return out;
  }
  std::string socket_, conf_;
};

// A shell command for a tmux pane: `stepchoir ARGS` (jack: on the test's JACK server), then its
// exit status ("EXIT=0") and whether the terminal reads lines and echoes again ("TTY: icanon
// echo"); then the pane stays, with its screen.
std::string stepchoir_in_pane(const std::string &args, bool jack = true) {
  const char *jack_server = std::getenv("JACK_DEFAULT_SERVER");
  if (jack && !jack_server) throw std::runtime_error("no JACK server");
  return std::string(jack ? std::string("env JACK_DEFAULT_SERVER=") + jack_server + " " : "") + STEPCHOIR_BIN + " " + args +
         "; echo \"EXIT=$?\"; echo \"TTY: $(stty -a | tr ' ;' '\\n\\n' | grep -x -e icanon -e -icanon -e echo -e -echo | "
         "tr '\\n' ' ')\"; sleep 600";
}

// Whether the screen's row of motor m (it starts with the motor's number) starts with `text`.
bool row_starts(const std::string &screen, int m, const std::string &text) {
  char start[8];
  std::snprintf(start, sizeof start, "%2d  ", m);
  size_t at = 0;
  for (size_t end; (end = screen.find('\n', at)) != std::string::npos; at = end + 1)
    if (screen.compare(at, 4, start) == 0) return screen.compare(at, text.size(), text) == 0;
  return false;
}

// Whether every motor of the Uno's four is silent on the screen.
bool all_silent(const std::string &screen) {
  for (int m = 0; m < 4; ++m)
    if (!row_starts(screen, m, " " + std::to_string(m) + "  --")) return false;
  return true;
}

// Checks that the screen shows text / that motor m's row starts with text; the screen with a failure.
void expect_text(const std::string &screen, const std::string &text) {
  INFO("the screen:\n" << screen);
  CHECK(screen.find(text) != std::string::npos);
}
void expect_row(const std::string &screen, int m, const std::string &text) {
  INFO("the screen:\n" << screen);
  CHECK(row_starts(screen, m, text));
}

// Types q, then checks that the command said `goodbye`, exited 0 and gave the terminal back:
// reading lines and echoing, out of the alternate screen, the cursor shown.
void quit_and_check_terminal(TmuxSession &tmux, const std::string &goodbye) {
  tmux.key("q");
  const std::string screen = tmux.wait_for("TTY:");
  expect_text(screen, goodbye);
  expect_text(screen, "EXIT=0");
  expect_text(screen, "TTY: icanon echo");
  CHECK(tmux.format("#{alternate_on}") == "0\n");
  CHECK(tmux.format("#{cursor_flag}") == "1\n");
}

}  // namespace

TEST_CASE("live: the console under tmux shows a key's note and Hz, and its octave and panic keys act",
          "[e2e][live][console][pacing]") {
  e2e::LiveRig rig("console");
  TmuxSession tmux(stepchoir_in_pane("live --config " + rig.config_path), 80, 24);
  std::string screen;  // the latest capture
  // The Uno's four motors, silent, their carriages in the middle of the rail and no endstop hits
  // (from the board's status replies, once a second).
  const std::string middle = "|-------------------o------------------|";
  screen = tmux.wait_until([&](const std::string &s) { return all_silent(s) && s.find(middle) != std::string::npos; });
  expect_text(screen, "stepchoir live  preset -  transpose +0");
  REQUIRE(all_silent(screen));
  expect_row(screen, 3, " 3  --                         0  " + middle);
  wait_ms(300);  // JACK takes the new connection

  // A4: motor 0's row shows the note, its Hz and no bend; the MIDI line the key.
  double down_s[128] = {}, up_s[128] = {};
  auto press = [&](uint8_t key) { down_s[key] = rig.keys.send(stepchoir::note_on(0, key, 64)); };
  auto lift = [&](uint8_t key) { up_s[key] = rig.keys.send(stepchoir::note_off(0, key)); };
  press(69);
  screen = tmux.wait_for("440.00");
  expect_row(screen, 0, " 0  A4      440.00     +0      0  |");
  expect_text(screen, "last: on  ch1 A4 64");
  wait_ms(300);
  lift(69);
  const double first_a4_ms = (up_s[69] - down_s[69]) * 1e3;
  screen = tmux.wait_until(all_silent);
  CHECK(all_silent(screen));

  // The octave key: the title says so, and the next A4 sounds as A5.
  wait_ms(200);
  tmux.key("o");
  screen = tmux.wait_for("transpose +12");
  expect_text(screen, "transpose +12");
  press(69);
  screen = tmux.wait_for("880.00");
  expect_row(screen, 0, " 0  A5      880.00     +0      0  |");
  wait_ms(300);
  lift(69);
  wait_ms(300);

  // Two keys held; the panic key (space) silences both while they are still down.
  press(60);
  press(64);
  screen = tmux.wait_for("659.26");  // E5 (E4 + 12)
  expect_text(screen, " C5 ");
  wait_ms(300);
  const double panic_s = tmux.key("Space");
  screen = tmux.wait_until(all_silent);
  CHECK(all_silent(screen));
  expect_text(screen, "panic: every motor silenced");
  wait_ms(400);
  lift(60);
  lift(64);
  wait_ms(300);

  // q: the process ends with status 0 and the terminal as it was.
  quit_and_check_terminal(tmux, "live: every motor silenced");
  REQUIRE(rig.vb.stop() == 0);

  // The trace: A4, then A5 after the octave key, then C5 and E5 until the panic; nothing else.
  const tr::Trace t = tr::read_trace(rig.trace_path);
  const std::vector<e2e::Sounded> sounded = e2e::sounded_notes_logged(t);
  REQUIRE(sounded.size() == 4);
  struct Expected {
    int pitch;
    double held_ms;
  };
  for (const Expected &e : {Expected{69, first_a4_ms}, Expected{81, (up_s[69] - down_s[69]) * 1e3},
                            Expected{72, (panic_s - down_s[60]) * 1e3},
                            Expected{76, (panic_s - down_s[64]) * 1e3}}) {
    const e2e::Sounded *found = nullptr;
    for (size_t m = 0; m < 4 && !found; ++m) found = e2e::find_sounded(sounded, m, e.pitch);
    INFO("note " << e.pitch);
    REQUIRE(found);
    const double ms = (found->end_s - found->start_s) * 1e3;
    std::printf("console: note %d on motor %zu: %+.4f cents, %.1f ms (expected %.1f ms)\n", e.pitch, found->motor,
                (found->pitch - e.pitch) * 100.0, ms, e.held_ms);
    CHECK(std::fabs(found->pitch - e.pitch) < 0.01);
    CHECK(std::fabs(ms - e.held_ms) < 80);  // the panic's notes: ended by it, not by their keys
  }
}

TEST_CASE("jam: the console under tmux shows the song's place, its clock and the keyboard's motors",
          "[e2e][jam][console][pacing]") {
  e2e::LiveRig rig("console-jam");
  TmuxSession tmux(stepchoir_in_pane(std::string("jam ") + STEPCHOIR_SONGS_DIR + "/canon.sng --song-motors 0,1 --midi " +
                                     Sender::kPort + " --midi-api jack --config " + rig.config_path),
                   80, 24);
  std::string screen = tmux.wait_for("song clock");
  expect_text(screen, "stepchoir jam  playing 0:");
  // The keyboard's motors, numbered as the rig counts them: 2 and 3 (the song plays 0 and 1).
  expect_row(screen, 2, " 2  --");
  expect_row(screen, 3, " 3  --");
  CHECK_FALSE(row_starts(screen, 0, " 0  "));
  wait_ms(300);  // JACK takes the new connection
  rig.keys.send(stepchoir::note_on(0, 69, 64));
  screen = tmux.wait_for("440.00");
  expect_row(screen, 2, " 2  A4      440.00     +0  ");  // then its endstop hits once a status came
  rig.keys.send(stepchoir::note_off(0, 69));
  quit_and_check_terminal(tmux, "jam: stopped, every motor silent");
}

// Whether some motor's row (0-3) shows a note and its Hz: " 0  A4      440.00    +0   ...".
bool some_motor_sounds(const std::string &screen) {
  size_t at = 0;
  for (size_t end; (end = screen.find('\n', at)) != std::string::npos; at = end + 1) {
    const std::string row = screen.substr(at, end - at);
    if (row.size() > 20 && row[0] == ' ' && row[1] >= '0' && row[1] <= '3' && row.compare(2, 2, "  ") == 0 &&
        row[4] >= 'A' && row[4] <= 'G' && row.find('.') != std::string::npos)
      return true;
  }
  return false;
}

TEST_CASE("play: the console under tmux shows the song's motors, pauses on space and quits on q",
          "[e2e][play][console]") {
  const std::string trace = e2e::scratch("console-play.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace, "--quiet", "--no-measure"});
  TmuxSession tmux(stepchoir_in_pane(std::string("play ") + STEPCHOIR_SONGS_DIR + "/canon.sng --port " + vb.pty(), false),
                   80, 24);
  std::string screen = tmux.wait_until([](const std::string &s) {
    return s.find("stepchoir play  playing 0:") != std::string::npos && some_motor_sounds(s);
  });
  expect_text(screen, "stepchoir play  playing 0:");
  expect_text(screen, "space:pause/resume");
  {
    INFO("the screen:\n" << screen);
    CHECK(some_motor_sounds(screen));
  }
  tmux.key("Space");
  screen = tmux.wait_for("stepchoir play  paused 0:");
  expect_text(screen, "stepchoir play  paused 0:");
  quit_and_check_terminal(tmux, "play: stopped, every motor silent");
}

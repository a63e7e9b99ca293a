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
#include "console_pane.h"
#include "core/midi_event.h"
#include "e2e_more.h"
#include "live_rig.h"
#include "trace.h"

namespace tr = sc::trace;

using namespace console_pane;

namespace {

// Whether every motor of the Uno's four is silent on the screen.
bool all_silent(const std::string &screen) {
  for (int m = 0; m < 4; ++m)
    if (!row_starts(screen, m, " " + std::to_string(m) + "  --")) return false;
  return true;
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

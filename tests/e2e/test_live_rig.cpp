// test_live_rig.cpp: `stepchoir live` and the rig file, end to end on the real firmware through
// a JACK keyboard: without a port it starts the file's virtual boards (a Mega and an Uno, one
// pool) and homes their switched carriages first (home_on_start); the file names the board, configures its motor
// (5 us pulses) and transposes it; a board met before, its crystal 0.5 % fast, plays the
// keyboard in tune in real time (its crystal from the host's memory, config/board_memory.h);
// and a board reset with its link up (its button) is set up again and its held note restored,
// an Uno's at once and a Mega's once live has kept quiet for its bootloader.
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "core/midi_event.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "known_board.h"
#include "live_checks.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;
using namespace live_checks;

TEST_CASE("live: without a port it starts the rig file's virtual boards, a Mega and an Uno, homes their "
          "switched carriages first, and plays on them",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string config_path = e2e::scratch("live-own-board.toml");
  const std::string trace_mega = e2e::scratch("live-own-board.csv"), trace_uno = e2e::scratch("live-own-board-2.csv");
  std::remove(trace_mega.c_str());
  std::remove(trace_uno.c_str());
  const int64_t travel = 3200;  // the virtual boards' rails
  {
    // Two boards with no port (live starts both, one pool), home_on_start: each board's three
    // switched carriages go to the middle before the keyboard plays.
    std::ofstream f(config_path);
    f << "home_on_start = true\n";
    for (const char *kind : {"mega", "uno"}) {
      f << "[[boards]]\nboard = \"" << kind << "\"\n";
      for (int m = 0; m < 4; ++m) f << "[[boards.motors]]\ntravel_steps = " << travel << "\nhome_speed = 40.0\n";
    }
  }
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--midi-api", "jack", "--midi",
                                Sender::kPort, "--vboard-trace", trace_mega, "--quiet"},
                               true);
  std::string said, homing, line;
  while (live.read_line(&line, 30000) && line.find("-> 9 motors") == std::string::npos)
    (line.rfind("live: no --port", 0) == 0 ? said : homing) += line + "\n";
  INFO("stepchoir live said: " << said << homing << line);
  CHECK(said.find("live: no --port: playing on the virtual board (mega, bundled firmware)") == 0);
  CHECK(said.find("live: no --port: playing on the virtual board (uno, bundled firmware)") != std::string::npos);
  REQUIRE(line.find("-> 9 motors") != std::string::npos);
  for (int m = 0; m < 3; ++m) {
    const std::string done = "motor " + std::to_string(m) + ": in the middle, position 1600";
    CHECK(homing.find(done) != homing.rfind(done));  // on both boards
  }
  CHECK(homing.find("motor 3 has no end switch: not homed") != std::string::npos);
  settle();
  const double on_s = keys.send(stepchoir::note_on(0, 69, kSoft));
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const double off_s = keys.send(stepchoir::note_off(0, 69));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  CHECK(live.signal_and_wait(SIGTERM) == 0);  // stops its virtual boards, which write their traces

  const tr::Trace trace = tr::read_trace(trace_mega), uno = tr::read_trace(trace_uno);
  CHECK(trace.board == "mega");
  CHECK(uno.board == "uno");
  // The key: one note at its pitch, on one of the pool's motors (either board), after the
  // homing moves.
  std::vector<std::pair<const tr::Trace *, Played>> at_69;
  for (const tr::Trace *t : {&trace, &uno})
    for (const Played &p : played_notes(*t)) {
      UNSCOPED_INFO(t->board << ": played " << p.pitch << " on motor " << p.motor << " for " << p.end_s - p.start_s << " s");
      if (std::fabs(p.pitch - 69) < kPitchToleranceSemitones) at_69.push_back({t, p});
    }
  REQUIRE(at_69.size() == 1);
  const tr::Trace &keyed = *at_69[0].first;
  const Played key = at_69[0].second;
  CHECK(std::fabs((key.end_s - key.start_s) - (off_s - on_s)) < kTimeToleranceS + pacing_error_s(keyed));
  // Homing from the middle: each switched carriage reached the far end (the rail measured) and
  // stood in the middle when the key came.
  for (const tr::Trace *t : {&trace, &uno})
    for (int m = 0; m < 3; ++m) {
      INFO(t->board << " motor " << m);
      int64_t position = travel / 2;
      bool reached_far_end = false;
      for (const auto &step : t->motor[size_t(m)].steps) {
        if (t == &keyed && keyed.board_seconds(step.rise_cycle) >= key.start_s) break;
        position = step.position;
        reached_far_end = reached_far_end || step.position == travel;
      }
      CHECK(reached_far_end);
      CHECK(position == travel / 2);
    }
}

TEST_CASE("live: a configuration file names the board, configures its motor and transposes it, and a board "
          "met before with a crystal 0.5 % fast plays in tune",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("live-config.csv"), config_path = e2e::scratch("live-config.toml");
  // The board's id in its EEPROM, and its crystal in the host's memory (XDG_CACHE_HOME, which
  // the child reads): live's keyboard takes it, so the notes are in tune in real time.
  const e2e::KnownBoard known("live-config", 0x010000000000002a, 5000.0);
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure", "--eeprom", known.eeprom,
                    "--clock-ppm", "5000"});
  {
    std::ofstream f(config_path);
    f << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n"
      << "[allocation]\npolicy = \"channel\"\n"
      << "[[boards]]\nport = \"" << vb.pty() << "\"\n"
      << "[[boards.motors]]\ntranspose = 12\npulse_us = 5\n";
  }
  {  // `stepchoir ports` lists the keyboard among the JACK MIDI inputs
    stepchoir::ChildProcess ports({STEPCHOIR_BIN, "ports", "--midi-api", "jack"}, true);
    const std::string listed = ports.read_rest(10000);
    INFO("stepchoir ports said:\n" << listed);
    CHECK(ports.wait() == 0);
    CHECK(listed.find("MIDI inputs (jack):") != std::string::npos);
    CHECK(listed.find(std::string(":") + Sender::kPort) != std::string::npos);
  }
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
  wait_ready(live, "-> 4 motors, policy channel");
  keys.send(stepchoir::note_on(0, 60, 100));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  keys.send(stepchoir::note_off(0, 60));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);

  const tr::Trace trace = tr::read_trace(trace_path);
  const auto played = played_notes(trace);
  REQUIRE(played.size() == 1);
  CHECK(played[0].motor == 0);
  // In real time: the board's cycles run 0.5 % fast (8.6 cents sharp if the keyboard took
  // them for 16 MHz); within a cent.
  REQUIRE(trace.clock_ppm == 5000.0);
  const double heard = played[0].pitch + 12 * std::log2(1 + trace.clock_ppm / 1e6);
  INFO("heard " << heard << " for note 72 (the board's own clock says " << played[0].pitch << ")");
  CHECK(std::fabs(heard - 72) < 0.01);
  const auto width = tr::min_pulse_width_cycles(trace.motor[0].steps);
  REQUIRE(width);
  CHECK(*width >= 5 * 16);      // 5 us at 16 MHz
  // not the default 2 us, nor much longer: the step ISR lowers STEP a loop pass after the
  // pulse's end (measured 111 cycles for the 80 asked)
  CHECK(*width < 5 * 16 + 48);
}

TEST_CASE("live: a board reset with its link up (its button) is set up again from the rig file, and the held "
          "note sounds again - an Uno at once, a Mega held in its bootloader by live's bytes once live goes quiet",
          "[e2e][live][pacing]") {
  const std::string board = GENERATE(as<std::string>{}, "uno", "mega");
  INFO(board);
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("live-button-" + board + ".csv"),
                    config_path = e2e::scratch("live-button-" + board + ".toml");
  VboardProcess vb({"--board", board, "--auto-reset", "--trace", trace_path, "--quiet", "--no-measure"});
  std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n"
                             << "[allocation]\npolicy = \"channel\"\n"
                             << "[[boards]]\nport = \"" << vb.pty() << "\"\n"
                             << "[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 5\n";
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
  wait_ready(live, board == "uno" ? "-> 4 motors, policy channel" : "-> 5 motors, policy channel");
  keys.send(stepchoir::note_on(0, 60, 100));  // channel 1: motor 0, held across the reset
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  REQUIRE(::kill(vb.pid(), SIGUSR1) == 0);  // the reset button: the USB bridge stays up
  // The Uno's firmware starts and announces itself; the Mega's stk500v2 takes live's heartbeats
  // into its message loop and waits for 5 s of silence, which live keeps once the board has
  // sent nothing for 3.5 s.
  REQUIRE(wait_for_line(live, board == "uno" ? "the board restarted; setting it up again"
                                             : "the board stopped answering; waiting for it in silence"));
  REQUIRE(wait_for_line(live, "set up again"));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  keys.send(stepchoir::note_off(0, 60));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  REQUIRE(t.mcu_resets.size() == 2);  // live's open, then the button
  const uint64_t button = t.mcu_resets[1];
  // Motor 0: the held note before the reset and again after it, at its pitch.
  const auto notes = tr::segment_notes(t.motor[0].steps, t.f_cpu_hz);
  REQUIRE(notes.size() == 2);
  CHECK(notes[0].end_cycle < button);
  CHECK(notes[1].start_cycle > button);
  for (const auto &n : notes) CHECK(std::fabs(n.midi_note - 60) < kPitchToleranceSemitones);
  CHECK(double(notes[1].end_cycle - notes[1].start_cycle) / t.f_cpu_hz > 0.4);
  // Back after the Uno's 1.4 s bootloader; the Mega's after live's wait for an answer (3.5 s
  // from the last status reply, up to a second before the button) and the bootloader's 5 s of
  // silence (the simulated board keeps real time).
  const double back_s = double(notes[1].start_cycle - button) / t.f_cpu_hz;
  INFO("the held note sounded again " << back_s << " s after the button");
  if (board == "uno") CHECK(back_s < 2.5);
  else CHECK((back_s > 7.4 && back_s < 10.0));
  // After the reset the TB6600's 5 us pulses again, as before it: the rig file's configuration
  // was sent anew (the board's 2 us default measures about 98 cycles, the 5 us about 122: the
  // step ISR lowers STEP at its first pass after the pulse's end).
  std::vector<double> before_w, after_w;
  for (const auto &s : t.motor[0].steps) (s.rise_cycle > button ? after_w : before_w).push_back(s.width_cycles);
  REQUIRE_FALSE(before_w.empty());
  REQUIRE_FALSE(after_w.empty());
  std::sort(before_w.begin(), before_w.end());
  std::sort(after_w.begin(), after_w.end());
  INFO("pulses (cycles) before the reset: median " << before_w[before_w.size() / 2] << ", after: shortest "
                                                   << after_w.front() << ", median " << after_w[after_w.size() / 2]);
  CHECK(after_w.front() >= 5 * 16);
  CHECK(std::fabs(after_w[after_w.size() / 2] - before_w[before_w.size() / 2]) < 16);  // a microsecond
}

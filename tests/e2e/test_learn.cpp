// test_learn.cpp: MIDI learn end to end: `stepchoir live --learn` on a JACK keyboard and the real
// firmware on an Uno virtual board. The performer types preset_next and presses a pedal (CC 67),
// then mute_motor 0 and presses a button (CC 20); both are saved to the rig file. The pedal then
// switches to a preset a octave up and the button mutes motor 0, read from the trace's STEP
// edges; a second `stepchoir live` without --learn takes the saved pedal from the file.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "config/config.h"
#include "core/midi_event.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;

namespace {

void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// Reads the child's lines until one contains `want` (or 20 s pass); adds them to *said, and
// fails the test with all it said when none came.
void expect_line(stepchoir::ChildProcess &p, const std::string &want, std::string *said) {
  std::string line;
  while (p.read_line(&line, 20000)) {
    *said += line + "\n";
    if (line.find(want) != std::string::npos) return;
  }
  INFO("stepchoir live said:\n" << *said);
  FAIL("no line with: " << want);
}

}  // namespace

TEST_CASE("live: MIDI learn binds a pedal and a button, saves them, and they act", "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("learn.csv"), config_path = e2e::scratch("learn.toml");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n\n"
                             << "[[presets]]\nprogram = 1\nname = \"plain\"\n\n"
                             << "[[presets]]\nprogram = 2\nname = \"up\"\ntranspose = 12\n\n"
                             << "[[boards]]\nport = \"" << vb.pty() << "\"\n";
  double down_s[4] = {}, up_s[4] = {};
  auto note = [&](int i, uint8_t key) {
    down_s[i] = keys.send(stepchoir::note_on(0, key, 64));
    wait_ms(300);
    up_s[i] = keys.send(stepchoir::note_off(0, key));
    wait_ms(200);
  };
  auto press = [&](uint8_t cc) {
    keys.send(stepchoir::control_change(0, cc, 127));
    wait_ms(100);
    keys.send(stepchoir::control_change(0, cc, 0));
  };
  {
    stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet", "--learn"},
                                 stepchoir::ChildProcess::Options{true, false, false, true});
    std::string said;
    expect_line(live, "live: preset 1 plain", &said);
    wait_ms(300);  // JACK takes the new connection
    REQUIRE(live.write_stdin("preset_next\n"));
    expect_line(live, "live: learn: move the control for preset_next", &said);
    press(67);
    expect_line(live, "live: learned CC 67 on channel 1 -> preset_next, saved to " + config_path, &said);
    REQUIRE(live.write_stdin("13 0\n"));
    expect_line(live, "live: learn: move the control for mute_motor", &said);
    press(20);
    expect_line(live, "live: learned CC 20 on channel 1 -> mute_motor 0", &said);

    note(0, 60);  // plain: C4 on motor 0
    press(67);    // the learned pedal: the next preset
    expect_line(live, "live: preset 2 up", &said);
    note(1, 60);  // up: C5 on motor 0
    press(20);    // the learned button: motor 0 muted
    wait_ms(100);
    note(2, 62);  // D5 on motor 1
    CHECK(live.signal_and_wait(SIGTERM) == 0);
  }
  const stepchoir::LiveConfig saved = stepchoir::load_config(config_path);
  REQUIRE(saved.controls.size() == 2);
  CHECK(saved.controls[0].binding.action == stepchoir::Action::kPresetNext);
  CHECK(saved.controls[0].binding.cc == 67);
  CHECK(saved.controls[1].binding.action == stepchoir::Action::kMuteMotor);
  CHECK(saved.presets.size() == 2);  // the rest of the file is still there
  {
    stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
    std::string said;
    expect_line(live, "live: preset 1 plain", &said);
    wait_ms(300);
    press(67);  // the pedal from the file
    expect_line(live, "live: preset 2 up", &said);
    note(3, 64);  // up, nothing muted (a stage mute lasts one run): E5 on motor 0
    CHECK(live.signal_and_wait(SIGTERM) == 0);
  }
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  const std::vector<e2e::Sounded> sounded = e2e::sounded_notes_logged(t);
  struct Expected {
    size_t motor;
    int pitch;
  };
  const Expected expected[] = {{0, 60}, {0, 72}, {1, 74}, {0, 76}};
  REQUIRE(sounded.size() == 4);  // nothing else: the learning presses and the pedal played nothing
  for (size_t i = 0; i < 4; ++i) {
    INFO("note " << i << ": " << expected[i].pitch << " on motor " << expected[i].motor);
    const e2e::Sounded *found = e2e::find_sounded(sounded, expected[i].motor, expected[i].pitch);
    REQUIRE(found);
    const double cents = (found->pitch - expected[i].pitch) * 100.0;
    const double ms = (found->end_s - found->start_s) * 1e3, held_ms = (up_s[i] - down_s[i]) * 1e3;
    std::printf("learn: note %zu: %d on motor %zu: %+.4f cents, %.1f ms (key held %.1f ms)\n", i, expected[i].pitch,
                found->motor, cents, ms, held_ms);
    CHECK(std::fabs(cents) < 1.0);
    CHECK(std::fabs(ms - held_ms) < 80);
  }
}

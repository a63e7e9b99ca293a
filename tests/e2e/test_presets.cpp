// test_presets.cpp: program-change presets end to end: a JACK keyboard switches `stepchoir live`
// from a plain preset to a split one (transpose +12, keys below 60 on motors 0-1, 60 and above on
// motors 2-3) while a key is held, on the real firmware on an Uno virtual board; read from the
// trace's STEP edges: the held note stops at the change, nothing is left sounding, and each note
// after it sounds on its zone's motors at the transposed pitch.
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
#include "core/midi_event.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "score.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;

namespace {

void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

const char *kPresets = R"([[presets]]
program = 1
name = "plain"

[[presets]]
program = 2
name = "split"
transpose = 12
[[presets.zones]]
highest = 59
motors = [0, 1]
[[presets.zones]]
lowest = 60
motors = [2, 3]
)";

}  // namespace

TEST_CASE("live: a program change switches presets: the held note stops at once, then zones and transpose",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("presets.csv"), config_path = e2e::scratch("presets.toml");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n"
                             << kPresets << "[[boards]]\nport = \"" << vb.pty() << "\"\n";
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
  // Its lines until the first preset is announced.
  std::string said, line;
  while (said.find("live: preset 1 plain") == std::string::npos && live.read_line(&line, 30000)) said += line + "\n";
  INFO("stepchoir live said:\n" << said);
  REQUIRE(said.find("-> 4 motors") != std::string::npos);
  REQUIRE(said.find("live: preset 1 plain") != std::string::npos);
  wait_ms(300);  // JACK takes the new connection

  // When each key went down and up (s, the steady clock), by key.
  double down_s[128] = {}, up_s[128] = {};
  auto press = [&](uint8_t key) { down_s[key] = keys.send(stepchoir::note_on(0, key, 64)); };
  auto lift = [&](uint8_t key) { up_s[key] = keys.send(stepchoir::note_off(0, key)); };
  // Preset 1, "plain": a note alone (motor 0, as it is), then A4 held across the switch.
  press(72);
  wait_ms(400);
  lift(72);
  wait_ms(200);
  press(69);
  wait_ms(500);
  // Program 2 ("split", 1 on the wire) and at once a key of the upper zone: both reach the engine
  // in the same JACK period, so that note's first edge marks the switch on the board's clock.
  const double change_s = keys.send(stepchoir::MidiEvent{stepchoir::kMidiProgramChange, 1, 0, 0});
  press(67);  // G4 + 12: motor 2 (motors 0 and 1 are free, but low)
  REQUIRE(live.read_line(&line, 5000));
  CHECK(line == "live: preset 2 split");
  wait_ms(300);
  lift(69);  // the held key comes up after the switch
  wait_ms(200);
  for (uint8_t k : {64, 48, 52}) press(k);  // + 12: E5 on motor 3 (upper zone), C4 and E4 on motors 0 and 1
  wait_ms(600);
  for (uint8_t k : {67, 64, 48, 52}) lift(k);
  wait_ms(300);
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  const std::vector<e2e::Sounded> sounded = e2e::sounded_notes_logged(t);

  // Each expected note: its motor, the pitch it must sound (transposed in "split") and how long
  // its key was held (ms; the held A4: until the switch).
  struct Expected {
    size_t motor;
    int pitch;
    double held_ms;
  };
  auto held_ms = [&](uint8_t key) { return (up_s[key] - down_s[key]) * 1e3; };
  const std::vector<Expected> expected = {{0, 72, held_ms(72)},
                                          {0, 69, (change_s - down_s[69]) * 1e3},  // until the switch
                                          {2, 79, held_ms(67)},
                                          {3, 76, held_ms(64)},
                                          {0, 60, held_ms(48)},
                                          {1, 64, held_ms(52)}};
  REQUIRE(sounded.size() == expected.size());  // nothing else sounded
  const e2e::Sounded *held = nullptr, *first_split = nullptr;
  double worst_cents = 0;
  for (const Expected &e : expected) {
    const e2e::Sounded *found = e2e::find_sounded(sounded, e.motor, e.pitch);
    INFO("note " << e.pitch << " on motor " << e.motor);
    REQUIRE(found);
    const double cents = (found->pitch - e.pitch) * 100.0, ms = (found->end_s - found->start_s) * 1e3;
    if (std::fabs(cents) > std::fabs(worst_cents)) worst_cents = cents;
    std::printf("presets: note %d on motor %zu: %+.4f cents, %.1f ms (key held %.1f ms)\n", e.pitch, e.motor, cents,
                ms, e.held_ms);
    CHECK(std::fabs(cents) < 1.0);
    CHECK(std::fabs(ms - e.held_ms) < 80);  // it stopped when its key (or the switch) ended it: nothing stuck
    if (e.pitch == 69) held = found;
    if (e.pitch == 79) first_split = found;
  }
  REQUIRE(held);
  REQUIRE(first_split);
  // The held A4's last edge against the split's first note, which came with the program change.
  const double stop_ms = (first_split->start_s - held->end_s) * 1e3;
  std::printf("presets: the held note's last step %.2f ms before the new preset's first note; worst pitch error "
              "%+.4f cents\n", stop_ms, worst_cents);
  if (t.has_wall_start && tr::pacing_slipped_us(t) == 0)
    std::printf("presets: program change sent -> the held note's last step: %.1f ms (JACK period 21 ms)\n",
                (t.wall_seconds(held->end_s) - change_s) * 1e3);
  CHECK(stop_ms >= 0);
  CHECK(stop_ms < 5);
}

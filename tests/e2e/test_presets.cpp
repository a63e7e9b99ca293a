// test_presets.cpp: program-change presets end to end, a JACK keyboard playing `stepchoir live` on
// the real firmware on an Uno virtual board, read from the trace's STEP edges. A switch from a
// plain preset to a split one (transpose +12, keys below 60 on motors 0-1, 60 and above on
// motors 2-3) while a key is held: the held note stops at the change, nothing is left sounding,
// and each note after it sounds on its zone's motors at the transposed pitch. A preset that
// narrows motor 0's range ([[presets.motors]]): keys outside it fold by octaves into it on that
// motor, while motor 1 plays as the board has it. `stepchoir jam` takes the rig file's presets
// and controls for its keyboard's motors, by the pool numbers it prints.
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
#include "play_checks.h"
#include "jack_rig.h"
#include "score.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;

namespace {

void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// Program 1, active at start: the top level's settings.
const std::string kPlain = "[[presets]]\nprogram = 1\nname = \"plain\"\n\n";

const std::string kPresets = kPlain + R"([[presets]]
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

// Program 2 narrows motor 0 to C4-B4 and mutes motors 2 and 3: a key reaches motor 0 when motor 1
// is busy or would have to fold less.
const std::string kNarrow = kPlain + R"([[presets]]
program = 2
name = "narrow"
mute_motors = [2, 3]
[[presets.motors]]
motor = 0
lowest_note = 60
highest_note = 71
)";

// A JACK keyboard (`keys`) and `stepchoir live` with a rig file of `presets` on an Uno virtual
// board tracing to `trace_path`; `said` holds live's lines up to its first preset's.
struct PresetRig {
  JackServer jack{1024};
  Sender keys;
  const std::string trace_path;
  VboardProcess vb;
  stepchoir::ChildProcess live;
  std::string said;
  double down_s[128] = {}, up_s[128] = {};  // when each key went down and up (s, the steady clock)

  // name: the scratch files' stem. Returns once live announced "live: preset 1 ..." (or gave up
  // after 30 s: the test checks `said`) and JACK had time to connect the keyboard.
  PresetRig(const std::string &name, const std::string &presets)
      : trace_path(e2e::scratch(name + ".csv")),
        vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"}),
        live({STEPCHOIR_BIN, "live", "--config", write_config(name, presets, vb.pty()), "--quiet"}, true) {
    std::string line;
    while (said.find("live: preset 1 ") == std::string::npos && live.read_line(&line, 30000)) said += line + "\n";
    wait_ms(300);  // JACK takes the new connection
  }

  // A key down (velocity 64: one motor) and up on channel 1, and how long it was held (ms).
  void press(uint8_t key) { down_s[key] = keys.send(stepchoir::note_on(0, key, 64)); }
  void lift(uint8_t key) { up_s[key] = keys.send(stepchoir::note_off(0, key)); }
  double held_ms(uint8_t key) const { return (up_s[key] - down_s[key]) * 1e3; }

  // Stops live (SIGTERM) and the board; every note the trace holds, each listed in the report.
  std::vector<e2e::Sounded> stop() {
    CHECK(live.signal_and_wait(SIGTERM) == 0);
    REQUIRE(vb.stop() == 0);
    trace = tr::read_trace(trace_path);
    return e2e::sounded_notes_logged(trace);
  }
  tr::Trace trace;  // after stop()

 private:
  // Writes the rig file (the keyboard on JACK, the presets, the board at `pty`); its path.
  static std::string write_config(const std::string &name, const std::string &presets, const std::string &pty) {
    const std::string path = e2e::scratch(name + ".toml");
    std::ofstream(path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n"
                        << presets << "[[boards]]\nport = \"" << pty << "\"\n";
    return path;
  }
};

// A note the test expects: its motor, the pitch it must sound and how long it must last (ms).
struct Expected {
  size_t motor;
  int pitch;
  double held_ms;
};

// The note of `sounded` on e's motor at e's pitch (nullptr, a failure, when there is none),
// checked: within 1 cent, and lasting as long as e says within 80 ms (nothing stuck). Prints it
// with `label`; keeps the largest pitch error in *worst_cents.
const e2e::Sounded *check_note(const std::vector<e2e::Sounded> &sounded, const Expected &e, const char *label,
                               double *worst_cents) {
  const e2e::Sounded *found = e2e::find_sounded(sounded, e.motor, e.pitch);
  INFO("note " << e.pitch << " on motor " << e.motor);
  CHECK(found);
  if (!found) return nullptr;
  const double cents = (found->pitch - e.pitch) * 100.0, ms = (found->end_s - found->start_s) * 1e3;
  if (std::fabs(cents) > std::fabs(*worst_cents)) *worst_cents = cents;
  std::printf("%s: note %d on motor %zu: %+.4f cents, %.1f ms (key held %.1f ms)\n", label, e.pitch, e.motor, cents,
              ms, e.held_ms);
  CHECK(std::fabs(cents) < 1.0);
  CHECK(std::fabs(ms - e.held_ms) < 80);
  return found;
}

}  // namespace

TEST_CASE("live: a program change switches presets: the held note stops at once, then zones and transpose",
          "[e2e][live][pacing]") {
  PresetRig rig("presets", kPresets);
  std::string line;
  INFO("stepchoir live said:\n" << rig.said);
  REQUIRE(rig.said.find("-> 4 motors") != std::string::npos);
  REQUIRE(rig.said.find("live: preset 1 plain") != std::string::npos);

  // Preset 1, "plain": a note alone (motor 0, as it is), then A4 held across the switch.
  rig.press(72);
  wait_ms(400);
  rig.lift(72);
  wait_ms(200);
  rig.press(69);
  wait_ms(500);
  // Program 2 ("split", 1 on the wire) and at once a key of the upper zone: both reach the engine
  // in the same JACK period, so that note's first edge marks the switch on the board's clock.
  const double change_s = rig.keys.send(stepchoir::MidiEvent{stepchoir::kMidiProgramChange, 1, 0, 0});
  rig.press(67);  // G4 + 12: motor 2 (motors 0 and 1 are free, but low)
  REQUIRE(rig.live.read_line(&line, 5000));
  CHECK(line == "live: preset 2 split");
  wait_ms(300);
  rig.lift(69);  // the held key comes up after the switch
  wait_ms(200);
  for (uint8_t k : {64, 48, 52}) rig.press(k);  // + 12: E5 on motor 3 (upper zone), C4 and E4 on motors 0 and 1
  wait_ms(600);
  for (uint8_t k : {67, 64, 48, 52}) rig.lift(k);
  wait_ms(300);
  const std::vector<e2e::Sounded> sounded = rig.stop();
  const tr::Trace &t = rig.trace;

  // Each expected note: its motor, the pitch it must sound (transposed in "split") and how long
  // its key was held (ms; the held A4: until the switch).
  const std::vector<Expected> expected = {{0, 72, rig.held_ms(72)},
                                          {0, 69, (change_s - rig.down_s[69]) * 1e3},  // until the switch
                                          {2, 79, rig.held_ms(67)},
                                          {3, 76, rig.held_ms(64)},
                                          {0, 60, rig.held_ms(48)},
                                          {1, 64, rig.held_ms(52)}};
  REQUIRE(sounded.size() == expected.size());  // nothing else sounded
  const e2e::Sounded *held = nullptr, *first_split = nullptr;
  double worst_cents = 0;
  for (const Expected &e : expected) {
    const e2e::Sounded *found = check_note(sounded, e, "presets", &worst_cents);  // ended by its key or the switch
    REQUIRE(found);
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

TEST_CASE("live: a preset narrows a motor's range: keys outside it fold by octaves into it on that motor",
          "[e2e][live][pacing]") {
  PresetRig rig("preset-range", kNarrow);
  std::string line;
  INFO("stepchoir live said:\n" << rig.said);
  REQUIRE(rig.said.find("live: preset 1 plain") != std::string::npos);

  // Preset 1, "plain": C3 on motor 0 as the board has it (A0-C8).
  rig.press(48);
  wait_ms(400);
  rig.lift(48);
  wait_ms(200);
  rig.keys.send(stepchoir::MidiEvent{stepchoir::kMidiProgramChange, 1, 0, 0});
  REQUIRE(rig.live.read_line(&line, 5000));
  CHECK(line == "live: preset 2 narrow");
  wait_ms(200);
  // D3 takes motor 1 (motor 0 would fold it); G2 then finds motor 0 alone free: two octaves up.
  rig.press(50);
  wait_ms(100);
  rig.press(43);
  wait_ms(400);
  rig.lift(43);
  rig.lift(50);
  wait_ms(200);
  // D6 on motor 1 as it is; C6 on motor 0: two octaves down.
  rig.press(86);
  wait_ms(100);
  rig.press(84);
  wait_ms(400);
  rig.lift(84);
  rig.lift(86);
  wait_ms(300);
  const std::vector<e2e::Sounded> sounded = rig.stop();

  const std::vector<Expected> expected = {{0, 48, rig.held_ms(48)}, {1, 50, rig.held_ms(50)},
                                          {0, 67, rig.held_ms(43)}, {1, 86, rig.held_ms(86)},
                                          {0, 60, rig.held_ms(84)}};
  REQUIRE(sounded.size() == expected.size());  // nothing else sounded
  double worst_cents = 0;
  for (const Expected &e : expected) check_note(sounded, e, "preset range", &worst_cents);
  std::printf("preset range: worst pitch error %+.4f cents\n", worst_cents);
}

TEST_CASE("jam: the keyboard takes the rig file's presets and controls on its own motors while the song plays",
          "[e2e][jam][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string song = play_checks::write_test_song("jam-presets.mid");
  const std::string trace_path = e2e::scratch("jam-presets.csv"), rig = e2e::scratch("jam-presets.toml");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // The song on motors 0 and 1, the keyboard on 2 and 3. Program 2 transposes an octave up and
  // mutes motor 2 (motor 0, the song's, is left out with a warning); controller 20 mutes motor 3
  // on stage.
  std::ofstream(rig) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n" << kPlain
                     << "[[presets]]\nprogram = 2\nname = \"up\"\ntranspose = 12\nmute_motors = [0, 2]\n"
                     << "[[controls]]\naction = \"mute_motor\"\ncc = 20\nmotor = 3\n"
                     << "[[boards]]\nport = \"" << vb.pty() << "\"\n";
  stepchoir::ChildProcess jam({STEPCHOIR_BIN, "jam", song, "--tracks", "1,2", "--tempo", "0.5", "--config", rig,
                               "--song-motors", "0,1", "--quiet"},
                              true);
  std::string said, line;
  while (said.find("jam: the song on motors 0,1") == std::string::npos && jam.read_line(&line, 30000))
    said += line + "\n";
  INFO("stepchoir jam said:\n" << said);
  REQUIRE(said.find("on motors 2,3") != std::string::npos);
  wait_ms(300);  // JACK takes the new connection
  double down[128] = {}, up[128] = {};
  auto tap = [&](uint8_t key) {
    down[key] = keys.send(stepchoir::note_on(0, key, 64));  // velocity 64: one motor
    wait_ms(400);
    up[key] = keys.send(stepchoir::note_off(0, key));
    wait_ms(200);
  };
  tap(60);  // "plain": motor 2
  keys.send(stepchoir::MidiEvent{stepchoir::kMidiProgramChange, 1, 0, 0});
  bool switched = false;
  while (!switched && jam.read_line(&line, 5000)) switched = line == "jam: preset 2 up";
  CHECK(switched);
  tap(62);  // "up": motor 3 (motor 2 muted), D5
  keys.send(stepchoir::control_change(0, 20, 127));
  wait_ms(100);
  tap(64);  // both keyboard motors muted: nothing
  const std::string out = jam.read_rest(60000);
  INFO(out);
  CHECK(jam.wait() == 0);
  REQUIRE(vb.stop() == 0);

  std::vector<e2e::Sounded> keyboard;
  for (const e2e::Sounded &n : e2e::sounded_notes_logged(tr::read_trace(trace_path)))
    if (n.motor >= 2) keyboard.push_back(n);
  const std::vector<Expected> expected = {{2, 60, (up[60] - down[60]) * 1e3}, {3, 74, (up[62] - down[62]) * 1e3}};
  REQUIRE(keyboard.size() == expected.size());  // the muted key sounded nowhere
  double worst_cents = 0;
  for (const Expected &e : expected) check_note(keyboard, e, "jam presets", &worst_cents);
}

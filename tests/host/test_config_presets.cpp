// test_config_presets.cpp: the rig file's [[presets]]: every key is read, what a preset leaves
// out keeps the top level's (and what a [[presets.motors]] entry leaves out, that motor's own),
// mistakes are reported with their line and column, and each preset becomes the allocator
// configuration the engine switches to.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>

#include "config/config.h"
#include "config_errors.h"
#include "core/midi_event.h"

using namespace stepchoir;

namespace {

// A pool of `motors` motors, as `stepchoir live` builds it before the presets go over it.
AllocatorConfig pool(uint8_t motors) {
  AllocatorConfig c;
  c.motor_count = motors;
  return c;
}

// The message preset_config throws for the file's first preset over a pool of `motors`.
std::string pool_error_of(const std::string &text, uint8_t motors) {
  try {
    preset_config(pool(motors), parse_config(text, "f.toml").presets.at(0));
  } catch (const std::runtime_error &e) {
    return e.what();
  }
  return "";
}

const char *kTwoPresets = R"(
[allocation]
priority = "lowest"
[vibrato]
rate_hz = 6.0
depth_cents = 30.0
[velocity]
double_at = 90
[glide]
time_ms = 100

[[presets]]
program = 1
name = "plain"

[[presets]]
program = 2
name = "split"
bank = 130
policy = "poly"
priority = "highest"
transpose = 12
bend_range = 7
mute_motors = [4]
[presets.vibrato]
depth_cents = 80.0
[presets.velocity]
triple_at = 0
[presets.glide]
time_ms = 300
on = true
[[presets.zones]]
highest = 59
motors = [0, 1]
[[presets.zones]]
lowest = 60
channel = 2
motors = [2, 3]
)";

}  // namespace

TEST_CASE("config: presets: every key is read, and what a preset leaves out keeps the top level's", "[config]") {
  const LiveConfig c = parse_config(kTwoPresets, "f.toml");
  REQUIRE(c.presets.size() == 2);
  CHECK(c.glide.time_ms == 100);
  CHECK_FALSE(c.glide.on);
  const PresetSettings &plain = c.presets[0], &split = c.presets[1];
  CHECK(plain.program == 1);
  CHECK(plain.name == "plain");
  CHECK(plain.bank == -1);
  CHECK_FALSE(plain.policy);
  CHECK(plain.priority == Priority::kLowest);
  CHECK(plain.vibrato.rate_hz == 6.0);
  CHECK(plain.vibrato.depth_cents == 30.0);
  CHECK(plain.velocity.double_at == 90);
  CHECK(plain.glide.time_ms == 100);
  CHECK(plain.transpose == 0);
  CHECK(plain.bend_range == 2);
  CHECK(plain.zones.empty());
  CHECK(plain.where == "f.toml:12:1");
  CHECK(split.program == 2);
  CHECK(split.bank == 130);
  CHECK(split.policy == Policy::kPoly);
  CHECK(split.priority == Priority::kHighest);
  CHECK(split.transpose == 12);
  CHECK(split.bend_range == 7);
  CHECK(split.vibrato.rate_hz == 6.0);  // from the top level
  CHECK(split.vibrato.depth_cents == 80.0);
  CHECK(split.velocity.double_at == 90);
  CHECK(split.velocity.triple_at == 0);
  CHECK(split.glide.time_ms == 300);
  CHECK(split.glide.on);
  CHECK(split.mute_motors == std::vector<uint8_t>{4});
  REQUIRE(split.zones.size() == 2);
  CHECK(split.zones[0].lowest == 0);
  CHECK(split.zones[0].highest == 59);
  CHECK(split.zones[0].channel == -1);
  CHECK(split.zones[1].lowest == 60);
  CHECK(split.zones[1].channel == 1);
  CHECK(split.zones[1].motors == std::vector<uint8_t>{2, 3});
}

TEST_CASE("config: presets become the engine's allocator configurations over the pool", "[config]") {
  const LiveConfig c = parse_config(kTwoPresets, "f.toml");
  AllocatorConfig base = pool(5);
  base.priority = c.priority;
  base.vibrato = c.vibrato;
  const std::vector<LivePreset> presets = live_presets(c, base);
  REQUIRE(presets.size() == 2);
  CHECK(presets[0].name == "plain");
  CHECK(presets[0].program == 0);  // on the wire
  CHECK(presets[0].bank == -1);
  CHECK(presets[0].config.zone_count == 0);
  CHECK(presets[0].config.muted_motors == 0);
  CHECK(presets[0].config.glide.time_ms == 100);
  const AllocatorConfig &s = presets[1].config;
  CHECK(presets[1].program == 1);
  CHECK(presets[1].bank == 130);
  CHECK(s.motor_count == 5);
  CHECK(s.transpose == 12);
  CHECK(s.bend_range == 7);
  CHECK(s.priority == Priority::kHighest);
  CHECK(s.muted_motors == 0b10000);
  REQUIRE(s.zone_count == 2);
  CHECK(s.zones[0].motors == 0b0011);
  CHECK(s.zones[0].highest == 59);
  CHECK(s.zones[1].motors == 0b1100);
  CHECK(s.zones[1].channel == 1);
  CHECK(s.glide.on);
  CHECK(s.vibrato.depth_cents == 80.0);
  CHECK(Allocator::validate(s) == nullptr);
}

TEST_CASE("config: preset mistakes name the file, line and column", "[config]") {
  const std::string p = "[[presets]]\nprogram = 1\nname = \"a\"\n";
  CHECK(error_of(p) == "");
  CHECK(error_of("[[presets]]\nname = \"a\"\n") == "f.toml:1:1: a preset needs program = 1 to 128");
  CHECK(error_of("[[presets]]\nprogram = 1\n") == "f.toml:1:1: a preset needs name = \"...\"");
  CHECK(error_of("[[presets]]\nprogram = 0\nname = \"a\"\n") == "f.toml:2:11: program = 0: must be 1 to 128");
  CHECK(error_of("[[presets]]\nprogram = 129\nname = \"a\"\n") == "f.toml:2:11: program = 129: must be 1 to 128");
  CHECK(error_of(p + "bank = 16384\n") == "f.toml:4:8: bank = 16384: must be 0 to 16383");
  CHECK(error_of(p + "transpose = 49\n") == "f.toml:4:13: transpose = 49: must be -48 to 48");
  CHECK(error_of(p + "bend_range = 25\n") == "f.toml:4:14: bend_range = 25: must be 0 to 24");
  CHECK(error_of(p + "volume = 3\n") == "f.toml:4:10: unknown key 'volume' in [[presets]]");
  CHECK(error_of(p + "policy = \"any\"\n") == "f.toml:4:10: policy 'any': expected poly, channel or mono");
  CHECK(error_of(p + "priority = \"newest\"\n") ==
        "f.toml:4:12: priority 'newest': expected oldest, lowest or highest");
  CHECK(error_of(p + "mute_motors = [1, 32]\n") ==
        "f.toml:4:19: mute_motors: motor indexes are 0 to 31 (motor 0 is the first board's first)");
  CHECK(error_of(p + "[presets.glide]\ntime_ms = 2040\n") == "f.toml:5:11: time_ms = 2040: must be 0 to 2032");
  CHECK(error_of(p + "[presets.glide]\non = 1\n") == "f.toml:5:6: on: expected true or false");
  CHECK(error_of(p + "[presets.vibrato]\nrate = 5\n") == "f.toml:5:8: unknown key 'rate' in [presets.vibrato]");
  CHECK(error_of(p + "[presets.velocity]\ndouble_at = 200\n") == "f.toml:5:13: double_at = 200: must be 0 to 127");
  CHECK(error_of(p + "[[presets.zones]]\nlowest = 60\n") == "f.toml:4:1: a zone needs motors = [...]");
  CHECK(error_of(p + "[[presets.zones]]\nmotors = []\n") == "f.toml:5:10: a zone needs motors = [...]");
  CHECK(error_of(p + "[[presets.zones]]\nlowest = 70\nhighest = 60\nmotors = [0]\n") ==
        "f.toml:5:10: lowest must not be above highest");
  CHECK(error_of(p + "[[presets.zones]]\nchannel = 0\nmotors = [0]\n") == "f.toml:5:11: channel = 0: must be 1 to 16");
  CHECK(error_of(p + "[[presets.zones]]\nmotors = [0]\nkeys = 3\n") ==
        "f.toml:6:8: unknown key 'keys' in [[presets.zones]]");
  CHECK(error_of(p + "policy = \"mono\"\n[[presets.zones]]\nmotors = [0]\n") ==
        "f.toml:5:1: zones need policy = \"poly\"");
  CHECK(error_of("[allocation]\npolicy = \"channel\"\n" + p + "[[presets.zones]]\nmotors = [0]\n") ==
        "f.toml:6:1: zones need policy = \"poly\"");
  CHECK(error_of(p + p) == "f.toml:5:11: program 1: preset 'a' (f.toml:1:1) has it already");
  CHECK(error_of(p + "bank = 3\n" + p + "bank = 3\n") ==
        "f.toml:6:11: program 1 in bank 3: preset 'a' (f.toml:1:1) has it already");
  CHECK(error_of(p + p + "bank = 3\n") == "");  // another bank
  CHECK(error_of("presets = 1\n") == "f.toml:1:11: presets: expected [[presets]] tables");
  // Motors the pool lacks: found once the boards are greeted, named where the file lists them.
  CHECK(pool_error_of(p + "mute_motors = [4]\n", 4) == "f.toml:4:15: mute_motors: motor 4, but the boards have 4 motors (0 to 3)");
  CHECK(pool_error_of(p + "[[presets.zones]]\nmotors = [1, 5]\n", 4) ==
        "f.toml:5:10: motors: motor 5, but the boards have 4 motors (0 to 3)");
  CHECK(pool_error_of(p + "[[presets.zones]]\nmotors = [1, 3]\n", 4) == "");
}

TEST_CASE("config: the commented preset example, uncommented, is two presets", "[config]") {
  const std::string text = default_config_text();
  CHECK(parse_config(text, "default").presets.empty());
  CHECK(parse_config(text, "default").glide.time_ms == 0);
  std::string example;  // the lines indented "#   " from the first [[presets]] on, up to the boards
  std::istringstream lines(text.substr(text.find("#   [[presets]]")));
  for (std::string line; std::getline(lines, line) && !line.empty();)
    example += line.rfind("#   ", 0) == 0 ? line.substr(4) + "\n" : "\n";
  const LiveConfig c = parse_config(example, "example");
  REQUIRE(c.presets.size() == 2);
  CHECK(c.presets[1].name == "split");
  CHECK(c.presets[1].transpose == 12);
  CHECK(c.presets[1].glide.time_ms == 200);
  CHECK(c.presets[1].zones.size() == 2);
  REQUIRE(c.presets[1].motors.size() == 1);
  CHECK(c.presets[1].motors[0].motor == 0);
  CHECK(c.presets[1].motors[0].music.lowest_note == 40);
  CHECK(c.presets[1].motors[0].music.highest_note == 64);
}

// ---------------------------------------------------------------------------------------------
// [[presets.motors]]: one motor's range, transpose, tuning and mutes in a preset
// ---------------------------------------------------------------------------------------------

namespace {

// Board motor 0 with its own music, motor 1 as the board leaves it; preset "narrow" sets motor 0's
// range only and motor 2's transpose, tuning and mutes.
const char *kMotorPresets = R"([[boards]]
[[boards.motors]]
lowest_note = 36
highest_note = 84
transpose = -12
tuning_cents = 5.0
muted = [50]

[[presets]]
program = 1
name = "narrow"
[[presets.motors]]
motor = 0
lowest_note = 60
highest_note = 71
[[presets.motors]]
motor = 2
transpose = 7
tuning_cents = -3.5
muted = [61, 62]
)";

// The pool `stepchoir live` builds from c over `motors` motors: each listed motor's music, the
// board's clock kept (Hz).
AllocatorConfig pool_of(const LiveConfig &c, uint8_t motors) {
  AllocatorConfig base = pool(motors);
  for (size_t m = 0; m < c.boards.at(0).motors.size(); ++m) base.motors[m] = c.boards[0].motors[m].music;
  for (size_t m = 0; m < motors; ++m) base.motors[m].f_cpu_hz = 16001000;
  return base;
}

}  // namespace

TEST_CASE("config: a preset's motor entry reads the keys of [[boards.motors]], each left out empty", "[config]") {
  const LiveConfig c = parse_config(kMotorPresets, "f.toml");
  REQUIRE(c.presets.size() == 1);
  const std::vector<PresetMotorSettings> &motors = c.presets[0].motors;
  REQUIRE(motors.size() == 2);
  CHECK(motors[0].motor == 0);
  CHECK(motors[0].where == "f.toml:13:9");
  CHECK(motors[0].music.lowest_note == 60);
  CHECK(motors[0].music.highest_note == 71);
  CHECK_FALSE(motors[0].music.transpose);
  CHECK_FALSE(motors[0].music.tuning_cents);
  CHECK_FALSE(motors[0].music.muted);
  CHECK(motors[1].motor == 2);
  CHECK_FALSE(motors[1].music.lowest_note);
  CHECK_FALSE(motors[1].music.highest_note);
  CHECK(motors[1].music.transpose == 7);
  CHECK(motors[1].music.tuning_cents == -3.5);
  REQUIRE(motors[1].music.muted);
  CHECK(motors[1].music.muted->count() == 2);
  CHECK(motors[1].music.muted->test(61));
  CHECK(motors[1].music.muted->test(62));
  // The board's motor, read by the same reader.
  const MotorConfig &own = c.boards[0].motors[0].music;
  CHECK(own.lowest_note == 36);
  CHECK(own.highest_note == 84);
  CHECK(own.transpose == -12);
  CHECK(own.tuning_cents == 5.0);
  CHECK(own.muted.count() == 1);
}

TEST_CASE("config: a preset's motor entry replaces what it sets of that motor, the rest stays its own",
          "[config]") {
  const LiveConfig c = parse_config(kMotorPresets, "f.toml");
  const AllocatorConfig base = pool_of(c, 4);
  const AllocatorConfig p = preset_config(base, c.presets.at(0));
  REQUIRE(Allocator::validate(p) == nullptr);
  const MotorConfig &m0 = p.motors[0], &m2 = p.motors[2];
  CHECK(m0.lowest_note == 60);  // the preset's range
  CHECK(m0.highest_note == 71);
  CHECK(m0.transpose == -12);  // the board's motor's own
  CHECK(m0.tuning_cents == 5.0);
  CHECK(m0.muted == base.motors[0].muted);
  CHECK(m0.f_cpu_hz == 16001000);
  CHECK(m2.lowest_note == 21);  // the default range: motor 2 is not in [[boards.motors]]
  CHECK(m2.highest_note == 108);
  CHECK(m2.transpose == 7);
  CHECK(m2.tuning_cents == -3.5);
  CHECK(m2.muted.count() == 2);
  CHECK(m2.f_cpu_hz == 16001000);
  for (size_t m : {1, 3}) {  // no entry: as the pool has them
    CHECK(p.motors[m].lowest_note == base.motors[m].lowest_note);
    CHECK(p.motors[m].transpose == base.motors[m].transpose);
  }
  CHECK(base.motors[0].lowest_note == 36);  // the pool itself is unchanged

  // A key below the preset's range, on motor 0 alone: its own transpose, then folded by octaves up
  // into 60-71. Above the range: folded down.
  AllocatorConfig alone = p;
  alone.muted_motors = 0b1110;
  Allocator a(alone);
  sc::PeriodEntry out[Allocator::kMaxMotors];
  a.handle(note_on(0, 48, 64), out, Allocator::kMaxMotors);  // 48 - 12 = 36: up two octaves
  CHECK(a.motor(0).played_note == 60);
  a.handle(note_off(0, 48), out, Allocator::kMaxMotors);
  a.handle(note_on(0, 100, 64), out, Allocator::kMaxMotors);  // 100 - 12 = 88: down two octaves
  CHECK(a.motor(0).played_note == 64);
  // Under the pool's own configuration the same key plays as the board's motor has it.
  Allocator own(base);
  own.handle(note_on(0, 48, 64), out, Allocator::kMaxMotors);
  CHECK(own.motor(0).played_note == 36);
}

TEST_CASE("config: preset motor entry mistakes name the file, line and column", "[config]") {
  const std::string p = "[[presets]]\nprogram = 1\nname = \"a\"\n[[presets.motors]]\n";
  CHECK(error_of(p + "motor = 3\nlowest_note = 40\nhighest_note = 80\ntranspose = -48\ntuning_cents = 12.5\n"
                     "muted = []\n") == "");
  CHECK(error_of(p + "lowest_note = 40\n") ==
        "f.toml:4:1: a preset's motor entry needs motor = its index (0: the first board's first)");
  CHECK(error_of(p + "motor = 32\n") == "f.toml:5:9: motor = 32: must be 0 to 31");
  CHECK(error_of(p + "motor = \"0\"\n") == "f.toml:5:9: motor: expected an integer");
  CHECK(error_of(p + "motor = 0\nlowest_note = 72\nhighest_note = 60\n") ==
        "f.toml:4:1: lowest_note must not be above highest_note");
  CHECK(error_of(p + "motor = 0\nhighest_note = 128\n") == "f.toml:6:16: highest_note = 128: must be 0 to 127");
  CHECK(error_of(p + "motor = 0\ntranspose = -49\n") == "f.toml:6:13: transpose = -49: must be -48 to 48");
  CHECK(error_of(p + "motor = 0\nmuted = [60, 128]\n") == "f.toml:6:14: muted: MIDI notes are 0 to 127");
  CHECK(error_of(p + "motor = 0\nmuted_notes = [60]\n") ==
        "f.toml:6:15: unknown key 'muted_notes' in [[presets.motors]]");
  CHECK(error_of(p + "motor = 1\n[[presets.motors]]\nmotor = 1\n") ==
        "f.toml:7:9: motor 1: this preset sets it already (f.toml:5:9)");
  CHECK(error_of("[[presets]]\nprogram = 1\nname = \"a\"\nmotors = [0]\n") ==
        "f.toml:4:11: motors: expected [[presets.motors]] tables");
  // Against the pool, once the boards are greeted: a motor it lacks, and a range that is empty
  // with the motor's own other end.
  CHECK(pool_error_of(p + "motor = 4\n", 4) == "f.toml:5:9: motor: motor 4, but the boards have 4 motors (0 to 3)");
  CHECK(pool_error_of(p + "motor = 3\nlowest_note = 109\n", 4) ==
        "f.toml:5:9: motor 3: lowest_note 109 is above highest_note 108 (a key the entry leaves out is the "
        "motor's own)");
  CHECK(pool_error_of(p + "motor = 3\nlowest_note = 108\n", 4) == "");
}

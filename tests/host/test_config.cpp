// test_config.cpp: the live configuration file: the printed default loads to the defaults,
// every key is read, and mistakes are reported with their line; [[presets]] too, and each
// preset becomes the allocator configuration the engine switches to.
#include <catch2/catch.hpp>

#include <regex>
#include <sstream>
#include <string>

#include "config/config.h"

using namespace stepchoir;

namespace {

// The message of the error parse_config throws for text ("" when it does not throw).
std::string error_of(const std::string &text) {
  try {
    parse_config(text, "f.toml");
  } catch (const std::runtime_error &e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("config: the printed default loads to the defaults", "[config]") {
  const LiveConfig c = parse_config(default_config_text(), "default");
  const LiveConfig d;
  CHECK(c.midi_input == d.midi_input);
  CHECK(c.midi_api == d.midi_api);
  CHECK(c.policy == d.policy);
  CHECK(c.priority == d.priority);
  CHECK(c.sing_percussion == d.sing_percussion);
  CHECK_FALSE(c.sing_percussion);
  CHECK(c.a4_hz == d.a4_hz);
  CHECK(c.boards.empty());
}

TEST_CASE("config: the commented board example, uncommented, gives the default motor", "[config]") {
  std::string text = default_config_text();
  const size_t from = text.find("# [[boards]]");
  REQUIRE(from != std::string::npos);
  std::string example;  // the lines that are TOML once "# " is taken off: [[tables]] and key = value
  const std::regex toml_line(R"(^# (\[\[[a-z.]+\]\]|[a-z_]+ = .*)$)");
  std::istringstream lines(text.substr(from));
  for (std::string line; std::getline(lines, line);)
    if (std::regex_match(line, toml_line)) example += line.substr(2) + "\n";
  const LiveConfig c = parse_config(example, "example");
  REQUIRE(c.boards.size() == 1);
  CHECK(c.boards[0].port == "/dev/ttyACM0");
  REQUIRE(c.boards[0].motors.size() == 1);
  const MotorSettings &m = c.boards[0].motors[0];
  const sc::ConfigBody d = default_motor_hardware(0);
  CHECK(m.hardware.driver == d.driver);
  CHECK(m.hardware.microsteps == d.microsteps);
  CHECK(m.hardware.travel_steps == d.travel_steps);
  CHECK(m.hardware.pulse_us == d.pulse_us);
  CHECK(m.music.lowest_note == MotorConfig{}.lowest_note);
  CHECK(m.music.highest_note == MotorConfig{}.highest_note);
  CHECK(m.music.muted.none());
  CHECK(m.mono_channel == 0);
  const sc::DriverBody p = default_motor_power(0, sc::kDriverA4988);
  CHECK(m.power.sleep_pin == p.sleep_pin);
  CHECK(m.power.reset_pin == p.reset_pin);
  CHECK(m.power.idle == p.idle);
  CHECK(m.power.idle_ms == p.idle_ms);
  CHECK(m.power.wake_us == p.wake_us);
  const MotionSettings ms;
  CHECK(m.motion.steps_per_turn == ms.steps_per_turn);
  CHECK(m.motion.steps_per_mm == ms.steps_per_mm);
  CHECK(m.motion.acceleration == ms.acceleration);
  CHECK(m.motion.min_speed == ms.min_speed);
  CHECK(m.motion.max_speed == ms.max_speed);
  CHECK(m.motion.home_speed == ms.home_speed);
  CHECK(m.motion.backoff_mm == ms.backoff_mm);
  CHECK_FALSE(c.home_on_start);
}

TEST_CASE("config: motion keys, a turn's steps from the microsteps, and their mistakes", "[config]") {
  const LiveConfig c = parse_config("home_on_start = true\n[[boards]]\n[[boards.motors]]\nmicrosteps = 8\n"
                                    "[[boards.motors]]\nsteps_per_turn = 400\nsteps_per_mm = 5.0\nacceleration = 50.0\n"
                                    "min_speed = 2.0\nmax_speed = 90.0\nhome_speed = 7.5\nbackoff_mm = 1.5\n",
                                    "f.toml");
  CHECK(c.home_on_start);
  REQUIRE(c.boards.at(0).motors.size() == 2);
  const MotionSettings &a = c.boards[0].motors[0].motion, &b = c.boards[0].motors[1].motion;
  CHECK(a.steps_per_turn == 1600.0);  // 200 full steps x 8
  CHECK(a.steps_per_mm == 40.0);      // a turn is 40 mm
  CHECK(b.steps_per_turn == 400.0);
  CHECK(b.steps_per_mm == 5.0);
  CHECK(b.acceleration == 50.0);
  CHECK(b.min_speed == 2.0);
  CHECK(b.max_speed == 90.0);
  CHECK(b.home_speed == 7.5);
  CHECK(b.backoff_mm == 1.5);
  const std::string motor = "[[boards]]\n[[boards.motors]]\n";
  CHECK(error_of(motor + "min_speed = 50.0\nmax_speed = 10.0\n") == "f.toml:3:13: min_speed must not be above max_speed");
  CHECK(error_of(motor + "acceleration = 0.0\n") == "f.toml:3:16: acceleration: must be 1 to 100000");
  CHECK(error_of("home_on_start = 1\n") == "f.toml:1:17: home_on_start: expected true or false");
}

TEST_CASE("config: every key is read", "[config]") {
  const LiveConfig c = parse_config(R"(
a4_hz = 442
[midi]
input = "Keystation"
api = "jack"
[allocation]
policy = "channel"
priority = "highest"
sing_percussion = true
[[boards]]
port = "/dev/ttyACM1"
[[boards.motors]]
driver = "tb6600"
microsteps = 8
endstop_active_high = true
travel_steps = 0
pulse_us = 5
lowest_note = 36
highest_note = 84
transpose = -12
tuning_cents = 3.5
muted = [40, 52]
mono_channel = 3
sleep_pin = 14
reset_pin = 15
idle = "sleep"
idle_ms = 250
wake_us = 20
[[boards.motors]]
driver = "drv8825"
idle = "disable"
[[boards]]
port = "/dev/ttyACM2"
)",
                                     "full");
  CHECK(c.a4_hz == 442);
  CHECK(c.midi_input == "Keystation");
  CHECK(c.midi_api == "jack");
  CHECK(c.policy == Policy::kChannel);
  CHECK(c.priority == Priority::kHighest);
  CHECK(c.sing_percussion);
  REQUIRE(c.boards.size() == 2);
  CHECK(c.boards[1].port == "/dev/ttyACM2");
  REQUIRE(c.boards[0].motors.size() == 2);
  const MotorSettings &m = c.boards[0].motors[0];
  CHECK(m.hardware.motor == 0);
  CHECK(m.hardware.driver == sc::kDriverTb6600);
  CHECK(m.hardware.microsteps == 8);
  CHECK(m.hardware.endstop_active_high == 1);
  CHECK(m.hardware.travel_steps == 0);
  CHECK(m.hardware.pulse_us == 5);
  CHECK(m.music.lowest_note == 36);
  CHECK(m.music.highest_note == 84);
  CHECK(m.music.transpose == -12);
  CHECK(m.music.tuning_cents == 3.5);
  CHECK(m.music.muted.count() == 2);
  CHECK(m.music.muted.test(52));
  CHECK(m.mono_channel == 2);
  CHECK(c.boards[0].motors[1].mono_channel == 0);
  CHECK(c.boards[0].motors[1].hardware.motor == 1);
  CHECK(c.boards[0].motors[1].hardware.driver == sc::kDriverDrv8825);
  CHECK(m.power.motor == 0);
  CHECK(m.power.sleep_pin == 14);
  CHECK(m.power.reset_pin == 15);
  CHECK(m.power.idle == sc::kIdleSleep);
  CHECK(m.power.idle_ms == 250);
  CHECK(m.power.wake_us == 20);
  const sc::DriverBody &p1 = c.boards[0].motors[1].power;
  CHECK(p1.motor == 1);
  CHECK(p1.idle == sc::kIdleDisable);
  CHECK(p1.sleep_pin == sc::kPinNone);
  CHECK(p1.wake_us == 1700);  // the DRV8825's wake-up time by default
  CHECK(default_motor_power(2, sc::kDriverA4988).wake_us == 1000);
  CHECK(default_motor_power(2, sc::kDriverTb6600).wake_us == 5);
}

TEST_CASE("config: driver power mistakes name the file, line and column", "[config]") {
  const std::string motor = "[[boards]]\n[[boards.motors]]\n";
  CHECK(error_of(motor + "idle = \"sleep\"\n") ==
        "f.toml:3:8: idle = \"sleep\" needs sleep_pin, the Arduino pin wired to the driver's SLEEP");
  CHECK(error_of(motor + "idle = \"off\"\n") == "f.toml:3:8: idle 'off': expected none, sleep or disable");
  CHECK(error_of(motor + "sleep_pin = 1\n") == "f.toml:3:13: sleep_pin = 1: pins 0 and 1 are the board's serial link");
  CHECK(error_of(motor + "reset_pin = 200\n") == "f.toml:3:13: reset_pin = 200: must be -1 to 127");
  CHECK(error_of(motor + "sleep_pin = -2\n") == "f.toml:3:13: sleep_pin = -2: must be -1 to 127");
  CHECK(error_of(motor + "sleep_pin = 14\nreset_pin = 14\n") == "f.toml:4:13: reset_pin: the same pin as sleep_pin");
  CHECK(error_of(motor + "sleep_pin = \"A0\"\n") == "f.toml:3:13: sleep_pin: expected an integer");
  CHECK(error_of(motor + "idle_ms = 70000\n") == "f.toml:3:11: idle_ms = 70000: must be 0 to 65535");
  CHECK(error_of(motor + "wake_us = 2501\n") == "f.toml:3:11: wake_us = 2501: must be 0 to 2500");
  CHECK(error_of(motor + "sleep_pin = 14\nidle = \"sleep\"\nidle_ms = 0\nwake_us = 2500\n") == "");
}

TEST_CASE("config: mistakes name the file, line and what is wrong", "[config]") {
  CHECK(error_of("a4_hz = 442\n[midi\n").rfind("f.toml:2:", 0) == 0);
  CHECK(error_of("a4_hz = 442\npolicy = \"poly\"\n") .find("f.toml:2:") == 0);
  CHECK(error_of("a4_hz = 442\npolicy = \"poly\"\n").find("unknown key 'policy' in the top level") != std::string::npos);
  CHECK(error_of("[allocation]\npolicy = \"round-robin\"\n").find("f.toml:2:") == 0);
  CHECK(error_of("[allocation]\npolicy = \"round-robin\"\n").find("expected poly, channel or mono") != std::string::npos);
  CHECK(error_of("[allocation]\nsing_percussion = 1\n") == "f.toml:2:19: sing_percussion: expected true or false");
  CHECK(error_of("a4_hz = \"440\"\n").find("a4_hz: expected a number") != std::string::npos);
  CHECK(error_of("a4_hz = 5000\n").find("a4_hz: must be") != std::string::npos);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\nmicrosteps = 12\n").find("f.toml:3:") == 0);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\npulse_us = 1\n").find("pulse_us = 1: must be 2 to 10") != std::string::npos);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\nmuted = [40, 200]\n").find("muted: MIDI notes are 0 to 127") != std::string::npos);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\nlowest_note = 90\nhighest_note = 80\n").find("lowest_note must not be above") != std::string::npos);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\ndriver = \"l298\"\n").find("f.toml:3:") == 0);
  CHECK(error_of("[midi]\napi = \"coreaudio\"\n").find("api: expected alsa or jack") != std::string::npos);
  CHECK(error_of("[[boards]]\n[[boards.motors]]\nmono_channel = 0\n").find("mono_channel = 0: must be 1 to 16") !=
        std::string::npos);
  CHECK(error_of("boards = 3\n").find("boards: expected [[boards]] tables") != std::string::npos);
  CHECK(error_of("") == "");
}

TEST_CASE("config: a missing file is reported by path", "[config]") {
  CHECK_THROWS_WITH(load_config("/nonexistent/stepchoir.toml"), "/nonexistent/stepchoir.toml: cannot open");
}

TEST_CASE("config: the velocity table sets the doubling thresholds, and names a bad one by line and column", "[config]") {
  const LiveConfig d = parse_config(default_config_text(), "default");
  CHECK(d.velocity.double_at == 100);  // the printed default, and the built-in one
  CHECK(d.velocity.triple_at == 120);
  CHECK(LiveConfig{}.velocity.double_at == 100);
  CHECK(LiveConfig{}.velocity.triple_at == 120);
  const LiveConfig c = parse_config("[velocity]\ndouble_at = 90\ntriple_at = 0\n", "f.toml");
  CHECK(c.velocity.double_at == 90);
  CHECK(c.velocity.triple_at == 0);  // off
  CHECK(c.velocity.extra_motors(127) == 1);
  CHECK(parse_config("[velocity]\ntriple_at = 127\n", "f.toml").velocity.double_at == 100);  // the other keeps its default
  CHECK(error_of("[velocity]\ndouble_at = 128\n") == "f.toml:2:13: double_at = 128: must be 0 to 127");
  CHECK(error_of("[velocity]\ndouble_at = 90\ntriple_at = -1\n") == "f.toml:3:13: triple_at = -1: must be 0 to 127");
  CHECK(error_of("[velocity]\ntriple_at = 110.5\n") == "f.toml:2:13: triple_at: expected an integer");
  CHECK(error_of("[velocity]\nquadruple_at = 127\n") == "f.toml:2:16: unknown key 'quadruple_at' in [velocity]");
  CHECK(error_of("velocity = 100\n") == "f.toml:1:12: [velocity] must be a table");
}

// ---------------------------------------------------------------------------------------------
// [[presets]]
// ---------------------------------------------------------------------------------------------

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
}

// test_config.cpp: the rig file: the printed default loads to the defaults, every key is read,
// and mistakes are reported with their line and column ([[presets]]: test_config_presets.cpp).
#include <catch2/catch.hpp>

#include <regex>
#include <sstream>
#include <string>

#include "config/config.h"
#include "config_errors.h"

using namespace stepchoir;

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
  CHECK(error_of("[[boards]]\nboard = \"nano\"\n") == "f.toml:2:9: board 'nano': expected uno or mega");
}

TEST_CASE("config: a board named by its kind takes as many motors as it has", "[config]") {
  auto board = [](const std::string &kind, int motors) {
    std::string text = "[[boards]]\n" + (kind.empty() ? "" : "board = \"" + kind + "\"\n");
    for (int m = 0; m < motors; ++m) text += "[[boards.motors]]\ndriver = \"a4988\"\n";
    return text;
  };
  CHECK(error_of(board("uno", 4)) == "");
  CHECK(error_of(board("uno", 5)) == "f.toml:11:1: board 'uno' has 4 motors (motor 3 is its last)");
  CHECK(error_of(board("mega", 5)) == "");
  CHECK(error_of(board("mega", 6)) == "f.toml:13:1: board 'mega' has 5 motors (motor 4 is its last)");
  // A board whose kind is unsaid (its port, here or on the command line, tells it): up to what
  // the protocol addresses.
  CHECK(error_of(board("", 5)) == "");
  CHECK(error_of(board("", 9)) == "f.toml:18:1: a board has at most 8 motors");
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
board = "mega"
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
  CHECK(c.boards[1].board == "mega");
  CHECK(c.boards[0].board == "uno");  // left out: an Uno
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

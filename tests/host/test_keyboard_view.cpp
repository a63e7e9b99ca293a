// test_keyboard_view.cpp: the rig file's presets and controls as jam's keyboard takes them, when
// a song plays some of the pool's motors (config.h keyboard_view): pool numbers become the
// keyboard's own, what names a song motor is left out and told where; and a control learned on
// jam's console is saved by the rig's motor number (cli/learn_prompt.h).
#include <catch2/catch.hpp>

#include <optional>
#include <string>
#include <vector>

#include "cli/learn_prompt.h"
#include "config/config.h"

using namespace stepchoir;

namespace {

// An Uno's four motors; a song on 0 and 1, the keyboard on 2 and 3.
const char *kRig = R"([[presets]]
program = 1
name = "split"
mute_motors = [0, 3]
[[presets.zones]]
highest = 59
motors = [0, 1]
[[presets.zones]]
lowest = 60
motors = [1, 2]
[[presets.motors]]
motor = 2
transpose = 12
[[presets.motors]]
motor = 1
transpose = -12

[[controls]]
action = "mute_motor"
cc = 20
motor = 3
[[controls]]
action = "mute_motor"
cc = 21
motor = 0
[[controls]]
action = "panic"
cc = 22
)";

AllocatorConfig pool(uint8_t motors) {
  AllocatorConfig c;
  c.motor_count = motors;
  return c;
}

}  // namespace

TEST_CASE("config: jam's keyboard takes the presets and controls by its own motor numbers, the song's left out",
          "[config]") {
  const LiveConfig config = parse_config(kRig, "f.toml");
  std::vector<std::string> left_out;
  const LiveConfig view = keyboard_view(config, {2, 3}, &left_out);

  REQUIRE(view.presets.size() == 1);
  const PresetSettings &p = view.presets[0];
  CHECK(p.mute_motors == std::vector<uint8_t>{1});  // pool motor 3: the keyboard's second
  REQUIRE(p.zones.size() == 1);                      // the low zone had song motors only
  CHECK(p.zones[0].lowest == 60);
  CHECK(p.zones[0].motors == std::vector<uint8_t>{0});
  REQUIRE(p.motors.size() == 1);
  CHECK(p.motors[0].motor == 0);
  CHECK(p.motors[0].music.transpose == 12);
  REQUIRE(view.controls.size() == 2);
  CHECK(view.controls[0].binding.action == Action::kMuteMotor);
  CHECK(view.controls[0].binding.motor == 1);
  CHECK(view.controls[0].binding.cc == 20);
  CHECK(view.controls[1].binding.action == Action::kPanic);

  // Each song motor named, where: mute_motors' 0, both of the low zone's, the high zone's 1,
  // the [[presets.motors]] entry of motor 1, the control of motor 0.
  const std::vector<std::string> told = {
      "f.toml:4:15: motor 0 plays the song: left out of the keyboard's presets and controls",  "f.toml:7:10: motor 0 plays the song: left out of the keyboard's presets and controls",
      "f.toml:7:10: motor 1 plays the song: left out of the keyboard's presets and controls",  "f.toml:10:10: motor 1 plays the song: left out of the keyboard's presets and controls",
      "f.toml:15:9: motor 1 plays the song: left out of the keyboard's presets and controls", "f.toml:22:1: motor 0 plays the song: left out of the keyboard's presets and controls"};
  CHECK(left_out == told);

  // Over the keyboard's pool of two, the view's presets and controls hold; the file's do not.
  CHECK_NOTHROW(live_presets(view, pool(2)));
  CHECK_NOTHROW(live_controls(view, 2));
  CHECK_THROWS(live_presets(config, pool(2)));
  CHECK_THROWS(live_controls(config, 2));
}

TEST_CASE("config: with every motor the keyboard's, jam's view is the file's", "[config]") {
  const LiveConfig config = parse_config(kRig, "f.toml");
  std::vector<std::string> left_out;
  const LiveConfig view = keyboard_view(config, {0, 1, 2, 3}, &left_out);
  CHECK(left_out.empty());
  CHECK(view.presets[0].mute_motors == config.presets[0].mute_motors);
  CHECK(view.presets[0].zones.size() == 2);
  CHECK(view.presets[0].motors.size() == 2);
  CHECK(view.controls.size() == 3);
  CHECK(view.controls[1].binding.motor == 0);
}

TEST_CASE("console: jam's keyboard learns a motor by the rig's number and saves it so", "[config]") {
  const std::vector<size_t> shown = {2, 3};  // the song on motors 0 and 1
  CHECK(keyboard_motor(shown, 3) == std::optional<uint8_t>(1));
  CHECK(keyboard_motor(shown, 2) == std::optional<uint8_t>(0));
  CHECK_FALSE(keyboard_motor(shown, 1));  // the song's
  Binding learned;
  learned.action = Action::kMuteMotor;
  learned.cc = 20;
  learned.motor = 1;  // the keyboard's second motor
  CHECK(rig_binding(learned, shown).motor == 3);
  learned.action = Action::kPanic;
  learned.motor = 0;
  CHECK(rig_binding(learned, shown).motor == 0);  // no motor to map
  // Saved as the rig counts it, the control reads back onto the same keyboard motor.
  LiveConfig config;
  learned.action = Action::kMuteMotor;
  learned.motor = 1;
  config.controls.push_back(ControlSettings{rig_binding(learned, shown), "f.toml:1:1"});
  const LiveConfig view = keyboard_view(config, shown, nullptr);
  REQUIRE(view.controls.size() == 1);
  CHECK(view.controls[0].binding.motor == 1);
}

TEST_CASE("config: a preset whose zones are all the song's leaves jam's keyboard silent, not free", "[config]") {
  const LiveConfig config = parse_config(R"([[presets]]
program = 1
name = "bass split"
[[presets.zones]]
highest = 59
motors = [0]
[[presets.zones]]
lowest = 60
motors = [1]
)", "f.toml");
  std::vector<std::string> left_out;
  const LiveConfig view = keyboard_view(config, {2, 3}, &left_out);
  const PresetSettings &p = view.presets.at(0);
  CHECK(p.zones.empty());
  CHECK(p.mute_motors == std::vector<uint8_t>{0, 1});
  REQUIRE(left_out.size() == 3);
  CHECK(left_out[2] == "f.toml:1:1: preset 'bass split': no zone has a keyboard motor: the keyboard is silent in it");
}

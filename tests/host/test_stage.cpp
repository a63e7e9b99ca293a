// test_stage.cpp: stage actions and MIDI learn: the learned-controller table (buttons fire on a
// press, knobs on every value, one controller an action), the rig file's [[controls]] with its
// mistakes, saving a learned control into a file that keeps the rest, the learn prompt's
// parsing, and the live engine learning a pedal and acting on it on a fake link.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "cli/learn_prompt.h"
#include "config/config.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

MidiEvent cc(uint8_t ch, uint8_t n, uint8_t v) {
  return MidiEvent{static_cast<uint8_t>(kMidiControlChange | ch), n, v, 0};
}

// What claim() says of one control change: -1 not claimed, 0 claimed silently, 1 fired.
int claimed(ControlMap &map, const MidiEvent &e, StageAction *a = nullptr) {
  StageAction got;
  bool fire = false;
  if (!map.claim(e, &got, &fire)) return -1;
  if (a) *a = got;
  return fire ? 1 : 0;
}

std::string read_text(const std::string &path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST_CASE("stage: a button fires on a press, a knob on every value", "[stage]") {
  ControlMap map;
  REQUIRE(map.bind(Binding{0, 64, Action::kPresetNext, 0}));
  REQUIRE(map.bind(Binding{-1, 74, Action::kVibratoDepth, 0}));
  CHECK(claimed(map, cc(0, 64, 127)) == 1);
  CHECK(claimed(map, cc(0, 64, 0)) == 0);     // the release: claimed, nothing happens
  CHECK(claimed(map, cc(0, 64, 100)) == 1);   // pressed again
  CHECK(claimed(map, cc(0, 64, 100)) == 1);   // a button that sends presses only
  CHECK(claimed(map, cc(1, 64, 127)) == -1);  // another channel: the allocator's sustain
  CHECK(claimed(map, cc(0, 7, 127)) == -1);
  StageAction a;
  CHECK(claimed(map, cc(9, 74, 0), &a) == 1);  // any channel; a knob at 0 is a value too
  CHECK(a.action == Action::kVibratoDepth);
  CHECK(a.value == 0);
  CHECK(claimed(map, cc(3, 74, 90), &a) == 1);
  CHECK(a.value == 90);
  // One controller an action: pedal 64 learned for panic drops its preset_next, and a second
  // controller for panic drops the first.
  REQUIRE(map.bind(Binding{0, 64, Action::kPanic, 0}));
  REQUIRE(map.bind(Binding{0, 65, Action::kPanic, 0}));
  CHECK(map.size() == 2);
  CHECK(claimed(map, cc(0, 64, 127)) == -1);
  CHECK(claimed(map, cc(0, 65, 127), &a) == 1);
  CHECK(a.action == Action::kPanic);
  CHECK_FALSE(map.bind(Binding{0, 120, Action::kPanic, 0}));  // a channel mode message
  CHECK_FALSE(map.bind(Binding{16, 1, Action::kPanic, 0}));
}

TEST_CASE("stage: action names round-trip, and learn requests are read or refused", "[stage]") {
  for (size_t i = 0; i < kActionCount; ++i) {
    const auto a = parse_action(action_name(static_cast<Action>(i)));
    REQUIRE(a);
    CHECK(static_cast<size_t>(*a) == i);
  }
  CHECK_FALSE(parse_action("transpose"));
  std::string why;
  auto r = parse_learn_request("8", 4, &why);
  REQUIRE(r);
  CHECK(r->action == Action::kPresetNext);
  r = parse_learn_request("mute_motor 3", 4, &why);
  REQUIRE(r);
  CHECK(r->action == Action::kMuteMotor);
  CHECK(r->motor == 3);
  CHECK_FALSE(parse_learn_request("13 4", 4, &why));
  CHECK(why.find("0-3") != std::string::npos);
  CHECK_FALSE(parse_learn_request("14", 4, &why));
  CHECK(why.find("1-13") != std::string::npos);
  CHECK_FALSE(parse_learn_request("loud", 4, &why));
  CHECK(describe_control(Binding{0, 64, Action::kPanic, 0}) == "CC 64 on channel 1");
}

TEST_CASE("stage: [[controls]] in the rig file, and their mistakes with line and column", "[stage][config]") {
  const LiveConfig c = parse_config(
      "[[controls]]\naction = \"octave_up\"\ncc = 20\nchannel = 2\n\n"
      "[[controls]]\naction = \"mute_motor\"\ncc = 21\nmotor = 3\n",
      "f.toml");
  REQUIRE(c.controls.size() == 2);
  CHECK(c.controls[0].binding.action == Action::kOctaveUp);
  CHECK(c.controls[0].binding.cc == 20);
  CHECK(c.controls[0].binding.channel == 1);
  CHECK(c.controls[1].binding.channel == -1);
  CHECK(c.controls[1].binding.motor == 3);
  CHECK(live_controls(c, 4).size() == 2);
  CHECK_THROWS_WITH(live_controls(c, 3), Catch::Contains("f.toml:6:1: motor 3: the boards have 3 motors"));
  CHECK_THROWS_WITH(parse_config("[[controls]]\naction = \"louder\"\ncc = 1\n", "f.toml"), Catch::StartsWith("f.toml:2:10: action: expected one of transpose_up"));
  CHECK_THROWS_WITH(parse_config("[[controls]]\naction = \"panic\"\ncc = 120\n", "f.toml"), Catch::StartsWith("f.toml:3:6: cc"));
  CHECK_THROWS_WITH(parse_config("[[controls]]\naction = \"panic\"\n", "f.toml"), Catch::StartsWith("f.toml:1:1: a control needs cc"));
  CHECK_THROWS_WITH(parse_config("[[controls]]\naction = \"mute_motor\"\ncc = 3\n", "f.toml"), Catch::Contains("mute_motor needs motor"));
  CHECK_THROWS_WITH(parse_config("[[controls]]\naction = \"panic\"\ncc = 3\nknob = 1\n", "f.toml"), Catch::StartsWith("f.toml:4:8: unknown key 'knob'"));
}

TEST_CASE("stage: a learned control is saved into the rig file, replacing what it clashes with", "[stage][config]") {
  const std::string path = "/tmp/stepchoir-test-learn-" + std::to_string(::getpid()) + "/rig.toml";
  std::remove(path.c_str());
  save_control(path, Binding{0, 64, Action::kPresetNext, 0});  // the file and its directory are made
  LiveConfig c = load_config(path);
  REQUIRE(c.controls.size() == 1);
  {
    std::ofstream out(path, std::ios::trunc);
    out << "# my rig\na4_hz = 442\n\n[[controls]]\naction = \"panic\"  # the red pedal\ncc = 67\n\n"
           "[[controls]]\naction = \"preset_next\"\ncc = 64\nchannel = 1\n\n[glide]\ntime_ms = 100\n";
  }
  save_control(path, Binding{0, 64, Action::kOctaveUp, 0});  // the same pedal: preset_next goes
  save_control(path, Binding{-1, 1, Action::kVibratoDepth, 0});
  const std::string text = read_text(path);
  CHECK(text.find("# my rig\na4_hz = 442\n") == 0);
  CHECK(text.find("# the red pedal") != std::string::npos);
  CHECK(text.find("preset_next") == std::string::npos);
  c = load_config(path);
  CHECK(c.a4_hz == 442);
  CHECK(c.glide.time_ms == 100);
  REQUIRE(c.controls.size() == 3);
  CHECK(c.controls[0].binding.action == Action::kPanic);
  CHECK(c.controls[1].binding.action == Action::kOctaveUp);
  CHECK(c.controls[1].binding.channel == 0);
  CHECK(c.controls[2].binding.action == Action::kVibratoDepth);
  save_control(path, Binding{2, 30, Action::kPanic, 0});  // panic moves to another controller
  c = load_config(path);
  REQUIRE(c.controls.size() == 3);
  CHECK(c.controls[2].binding.cc == 30);
  std::remove(path.c_str());
}

TEST_CASE("stage: the engine learns a pedal, then the pedal steps presets and mutes a motor", "[stage][live]") {
  FakeLink link;
  const uint32_t f = 16000000;
  const AllocatorConfig pool = pool_config({{&link, 4, f}}, Policy::kPoly);
  LiveSession s({{&link, 4, f}}, pool, 3600 * 1000);
  LivePreset a{"a", 0, -1, pool}, b{"b", 1, -1, pool};
  b.config.transpose = 12;
  s.set_presets({a, b});
  REQUIRE(s.bind(Binding{-1, 20, Action::kMuteMotor, 0}));
  s.start();
  auto send = [&](const MidiEvent &e) { REQUIRE(s.midi_queue().try_enqueue(e)); };
  REQUIRE(s.learn(Action::kPresetNext));
  std::optional<Binding> got;
  send(cc(3, 66, 127));  // queued after the learn: the engine applies the learn first
  REQUIRE(eventually([&] { return bool(got = s.learned()); }));
  CHECK(got->cc == 66);
  CHECK(got->channel == 3);
  CHECK(s.preset() == 0);  // the learning press itself does nothing else
  send(cc(3, 66, 0));
  send(cc(3, 66, 127));
  REQUIRE(eventually([&] { return s.preset() == 1; }));
  send(cc(3, 66, 0));
  send(cc(3, 66, 127));  // wraps
  REQUIRE(eventually([&] { return s.preset() == 0; }));
  send(cc(0, 20, 127));  // the file's binding: motor 0 muted
  REQUIRE(eventually([&] { return s.stage_mutes() == 1u; }));
  send(note_on(0, 60, 64, monotonic_us()));
  REQUIRE(eventually([&] { return s.motor_note(1) == 60; }));
  CHECK(s.motor_note(0) == -1);
  CHECK(s.motor_period_q8(1) == hz_to_period_q8(note_hz(60), f));
  REQUIRE(s.perform(StageAction{Action::kOctaveUp, 127, 0}));  // a console key
  REQUIRE(eventually([&] { return s.stage_transpose() == 12; }));
  send(note_on(0, 62, 64, monotonic_us()));
  REQUIRE(eventually([&] { return s.motor_note(2) == 74; }));
  REQUIRE(s.perform(StageAction{Action::kSetlistNext, 127, 0}));
  REQUIRE(s.perform(StageAction{Action::kSetlistNext, 127, 0}));
  REQUIRE(s.perform(StageAction{Action::kSetlistPrevious, 127, 0}));
  REQUIRE(s.perform(StageAction{Action::kPanic, 127, 0}));
  REQUIRE(eventually([&] { return s.panics() == 1; }));
  CHECK(s.take_setlist_steps() == 1);
  CHECK(s.take_setlist_steps() == 0);
  CHECK(s.motor_note(1) == -1);
  CHECK(s.motor_note(2) == -1);
  s.stop();
}

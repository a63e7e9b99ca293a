// test_allocator_presets.cpp: what a preset sets in the allocator: split and layer zones (key range
// and channel -> motors), a preset-wide transpose, muted motors, the bend range and glide every
// channel starts with; and the program-change switch: the selector with bank select, and
// configure() releasing what sounded.
#include <catch2/catch.hpp>

#include <set>
#include <vector>

#include "allocator_rig.h"
#include "live/presets.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

namespace {

// Keys below 60 on motors 0-1, 60 and above on motors 2-3 (the "split" of the end-to-end test).
AllocatorConfig split(uint8_t motors = 4) {
  AllocatorConfig c = poly(motors);
  c.zone_count = 2;
  c.zones[0] = Zone{0, 59, -1, 0b0011};
  c.zones[1] = Zone{60, 127, -1, 0b1100};
  return c;
}

// Switches r's allocator to c and applies the silences that follow to the mirror.
void reconfigure(Rig &r, const AllocatorConfig &c) {
  REQUIRE(r.a.configure(c));
  sc::PeriodEntry out[Allocator::kMaxMotors];
  const size_t n = r.a.flush(out, Allocator::kMaxMotors);
  for (size_t i = 0; i < n; ++i) r.board[out[i].motor] = out[i].period_q8;
}

std::set<size_t> as_set(const std::vector<size_t> &v) { return {v.begin(), v.end()}; }

MidiEvent program_change(uint8_t ch, uint8_t program) {
  return MidiEvent{static_cast<uint8_t>(kMidiProgramChange | ch), program, 0, 0};
}

}  // namespace

TEST_CASE("zones: a split plays each key range on its own motors, stealing within the zone only") {
  Rig r(split());
  r.on(0, 72);  // without zones it would take motor 0
  CHECK(as_set(r.motors_on(0, 72)) == std::set<size_t>{2});
  r.on(0, 48);
  CHECK(as_set(r.motors_on(0, 48)) == std::set<size_t>{0});
  r.on(0, 50);
  r.on(0, 52);  // the low zone is full: steals its oldest (48), never a high motor
  CHECK(r.motors_on(0, 48).empty());
  CHECK(as_set(r.motors_on(0, 52)) == std::set<size_t>{0});
  CHECK(as_set(r.motors_on(0, 72)) == std::set<size_t>{2});
  CHECK(r.board[3] == 0);
  CHECK(r.board[0] == expected_period(52));
}

TEST_CASE("zones: overlapping zones layer a key, one voice each, and its note-off ends all of them") {
  AllocatorConfig c = poly(4);
  c.zone_count = 2;
  c.zones[0] = Zone{0, 127, -1, 0b0011};
  c.zones[1] = Zone{60, 72, -1, 0b1100};
  Rig r(c);
  r.on(0, 64);
  CHECK(as_set(r.motors_on(0, 64)) == std::set<size_t>{0, 2});
  CHECK_FALSE(r.a.motor(2).doubling);  // a layer, not a doubler
  r.on(0, 64);                         // struck again: each layer keeps its motor
  CHECK(as_set(r.motors_on(0, 64)) == std::set<size_t>{0, 2});
  r.on(0, 40);  // only the first zone covers it
  CHECK(as_set(r.motors_on(0, 40)) == std::set<size_t>{1});
  r.off(0, 64);
  CHECK(r.motors_on(0, 64).empty());
  r.off(0, 40);
  CHECK(r.all_silent());
}

TEST_CASE("zones: a loud note's doublers come from its zone's motors") {
  Rig r(split());
  r.on(0, 72, 127);  // wants two doublers; the high zone has one motor more
  CHECK(as_set(r.motors_on(0, 72)) == std::set<size_t>{2, 3});
  CHECK(r.board[0] == 0);
  CHECK(r.board[1] == 0);
}

TEST_CASE("zones: a channel zone takes only its channel, and a key no zone covers is not played") {
  AllocatorConfig c = poly(4);
  c.zone_count = 2;
  c.zones[0] = Zone{0, 127, 1, 0b0001};   // channel 2, every key
  c.zones[1] = Zone{60, 71, -1, 0b1110};  // any channel, one octave
  Rig r(c);
  r.on(1, 40);
  CHECK(as_set(r.motors_on(1, 40)) == std::set<size_t>{0});
  CHECK(r.on(0, 40).empty());  // channel 1 below the octave: no zone
  CHECK(r.on(0, 80).empty());
  CHECK(r.motors_on(0, 40).empty());
  r.on(0, 65);
  CHECK(as_set(r.motors_on(0, 65)) == std::set<size_t>{1});
  CHECK(r.sounding() == 2);
}

TEST_CASE("a preset's transpose adds to every motor's own before folding") {
  AllocatorConfig c = poly(2);
  c.transpose = 12;
  c.motors[1].transpose = -5;
  Rig r(c);
  r.on(0, 60);
  r.on(0, 62);
  CHECK(r.board[0] == expected_period(72));
  CHECK(r.a.motor(0).played_note == 72);
  CHECK(r.a.motor(0).note == 60);  // the key as received
  CHECK(r.board[1] == expected_period(62 + 12 - 5));
  c.transpose = 48;  // past the range: folds by octaves into it
  reconfigure(r, c);
  r.on(0, 100);
  // 100 + 48 - 5 = 143 folds down three octaves to 107 on motor 1; motor 0 would need four (148 to 100).
  CHECK(r.motors_on(0, 100) == std::vector<size_t>{1});
  CHECK(r.a.motor(1).played_note == 107);
}

TEST_CASE("muted motors play nothing, in every policy") {
  AllocatorConfig c = poly(3);
  c.muted_motors = 0b001;
  Rig r(c);
  r.on(0, 60);
  r.on(0, 62);
  r.on(0, 64);  // two motors left: the oldest is stolen, motor 0 stays silent
  CHECK(r.board[0] == 0);
  CHECK(r.sounding() == 2);
  AllocatorConfig mono = mono_config();  // motors 0 and 1 are channel 0's group
  mono.muted_motors = 0b0010;
  reconfigure(r, mono);
  r.on(0, 67);
  CHECK(r.a.motor(0).sounding);
  CHECK_FALSE(r.a.motor(1).sounding);
  AllocatorConfig channel = poly(3);
  channel.policy = Policy::kChannel;
  channel.muted_motors = 0b100;
  reconfigure(r, channel);
  CHECK(r.on(2, 60).empty());
  CHECK(r.on(1, 60).size() == 1);
}

TEST_CASE("a configuration's bend range and glide are where every channel starts, and where CC121 returns") {
  AllocatorConfig c = poly(2);
  c.bend_range = 12;
  c.glide = GlideConfig{320, true};
  Rig r(c);
  CHECK(r.a.bend_range_semitones(5) == 12.0);
  r.cc(0, kCcRpnMsb, 0);
  r.cc(0, kCcRpnLsb, 0);
  r.cc(0, kCcDataEntryMsb, 2);
  CHECK(r.a.bend_range_semitones(0) == 2.0);
  r.cc(0, kCcResetAllControllers, 0);
  CHECK(r.a.bend_range_semitones(0) == 12.0);
  // Glide on without CC65, 320 ms: the motor's next note slides from its last.
  r.at(note_on(0, 57, kSoft), 1000000);
  r.at(note_off(0, 57), 1100000);
  r.at(note_on(0, 69, kSoft), 1120000);
  CHECK(r.board[0] == expected_period(57));  // it starts where the last note was
  r.tick(1120000 + 160000);
  CHECK(r.board[0] == expected_period(63));  // halfway in cents
  r.tick(1120000 + 320000);
  CHECK(r.board[0] == expected_period(69));  // landed exactly
}

TEST_CASE("validate() covers zones, transpose, mutes, bend range and glide") {
  const AllocatorConfig good = split();
  CHECK(Allocator::validate(good) == nullptr);
  auto bad = [&](auto change) {
    AllocatorConfig c = good;
    change(c);
    return Allocator::validate(c) != nullptr;
  };
  CHECK(bad([](AllocatorConfig &c) { c.transpose = 49; }));
  CHECK(bad([](AllocatorConfig &c) { c.bend_range = 128; }));
  CHECK(bad([](AllocatorConfig &c) { c.glide.time_ms = 2033; }));
  CHECK(bad([](AllocatorConfig &c) { c.muted_motors = 0b10000; }));  // motor 4 of 4
  CHECK(bad([](AllocatorConfig &c) { c.zones[1].motors = 0b10000; }));
  CHECK(bad([](AllocatorConfig &c) { c.zones[1].motors = 0; }));
  CHECK(bad([](AllocatorConfig &c) { c.zones[0].lowest = 70; }));
  CHECK(bad([](AllocatorConfig &c) { c.zones[0].channel = 16; }));
  CHECK(bad([](AllocatorConfig &c) { c.zone_count = AllocatorConfig::kMaxZones + 1; }));
  CHECK(bad([](AllocatorConfig &c) { c.policy = Policy::kMono; }));  // zones are poly's
  CHECK_FALSE(bad([](AllocatorConfig &c) { c.muted_motors = 0b1111; }));
}

TEST_CASE("presets: a program change picks the preset with that program, a named bank first, others ignored") {
  std::vector<LivePreset> presets(4);
  presets[0] = LivePreset{"plain", 0, -1, poly(4)};
  presets[1] = LivePreset{"split", 1, -1, split()};
  presets[2] = LivePreset{"split bank 2", 1, 2 * 128 + 5, split()};
  presets[3] = LivePreset{"bank only", 7, 3, poly(4)};
  PresetSelector s;
  CHECK(s.select(program_change(0, 1), presets.data(), presets.size()) == 1);
  CHECK(s.select(program_change(3, 0), presets.data(), presets.size()) == 0);  // any channel
  CHECK(s.select(program_change(0, 99), presets.data(), presets.size()) == -1);  // no such program
  CHECK(s.select(note_on(0, 1, 64), presets.data(), presets.size()) == -1);      // not a program change
  // Bank select MSB 2, LSB 5 on channel 5: that bank's program 2 wins over the any-bank one.
  CHECK(s.select(control_change(4, kCcBankSelectMsb, 2), presets.data(), presets.size()) == -1);
  CHECK(s.select(control_change(4, kCcBankSelectLsb, 5), presets.data(), presets.size()) == -1);
  CHECK(s.bank(4) == 2 * 128 + 5);
  CHECK(s.select(program_change(4, 1), presets.data(), presets.size()) == 2);
  CHECK(s.select(program_change(0, 1), presets.data(), presets.size()) == 1);  // channel 1 is in bank 0
  // A preset that names a bank answers only in it.
  CHECK(s.select(program_change(4, 7), presets.data(), presets.size()) == -1);
  s.select(control_change(4, kCcBankSelectMsb, 0), presets.data(), presets.size());
  s.select(control_change(4, kCcBankSelectLsb, 3), presets.data(), presets.size());
  CHECK(s.select(program_change(4, 7), presets.data(), presets.size()) == 3);
}

TEST_CASE("presets: switching releases a held note with a silent entry, and the next note plays the new preset") {
  AllocatorConfig plain = poly(4);
  AllocatorConfig high = split();
  high.transpose = 12;
  Rig r(plain);
  r.on(0, 69);
  r.on(0, 64);
  r.cc(0, kCcSustain, 127);
  r.off(0, 64);  // held by the pedal
  REQUIRE(r.sounding() == 2);
  REQUIRE(r.a.configure(high));
  sc::PeriodEntry out[Allocator::kMaxMotors];
  const size_t n = r.a.flush(out, Allocator::kMaxMotors);
  REQUIRE(n == 2);  // a silent entry for each motor that sounded
  for (size_t i = 0; i < n; ++i) {
    CHECK(out[i].period_q8 == sc::kPeriodSilent);
    r.board[out[i].motor] = out[i].period_q8;
  }
  CHECK(r.all_silent());
  CHECK(r.off(0, 69).empty());  // its key comes up later: nothing to do
  CHECK_FALSE(r.a.sustain(0));  // the pedal is up in the new preset
  r.on(0, 72);
  CHECK(as_set(r.motors_on(0, 72)) == std::set<size_t>{2});
  CHECK(r.board[2] == expected_period(84));
  r.on(0, 48);
  CHECK(as_set(r.motors_on(0, 48)) == std::set<size_t>{0});
  CHECK(r.board[0] == expected_period(60));
}

TEST_CASE("zones and presets never allocate in the engine") {
  AllocatorConfig a = split(), b = poly(4);
  a.transpose = 7;
  a.muted_motors = 0b0001;
  a.zones[0].channel = 0;
  Rig r(a);
  std::vector<LivePreset> presets{{"a", 0, -1, a}, {"b", 1, -1, b}};
  PresetSelector s;
  sc::PeriodEntry out[Allocator::kMaxMotors];
  const size_t before = g_allocations;
  size_t entries = 0;
  for (int i = 0; i < 2000; ++i) {
    const MidiEvent e = i % 50 == 49 ? program_change(0, static_cast<uint8_t>(i / 50 % 2))
                                     : note_on(static_cast<uint8_t>(i % 2), static_cast<uint8_t>(30 + i * 7 % 60),
                                               static_cast<uint8_t>(i % 3 ? 127 : 0));
    const int chosen = s.select(e, presets.data(), presets.size());
    if (chosen >= 0) {
      r.a.configure(presets[static_cast<size_t>(chosen)].config);
      entries += r.a.flush(out, Allocator::kMaxMotors);
    } else {
      entries += r.a.handle(e, out, Allocator::kMaxMotors);
    }
  }
  CHECK(g_allocations == before);
  CHECK(entries > 100);
}

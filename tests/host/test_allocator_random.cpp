// test_allocator_random.cpp: the allocator under random play, against a model of which keys are
// alive: every motor on one live note (a loud poly note's doublers in unison with its own motor),
// in range and in tune, and silence at the end.
#include <catch2/catch.hpp>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "allocator_rig.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

// ---------------------------------------------------------------------------------------------
// Random play against a model of which keys are alive
// ---------------------------------------------------------------------------------------------

namespace {
// What the keyboard and pedals did, independent of motors: a key is alive while held or while
// the pedal holds it after release; order keeps each channel's alive keys, newest last.
struct KeyModel {
  bool held[16][128] = {};
  bool pedalled[16][128] = {};
  bool pedal[16] = {};
  std::vector<uint8_t> order[16];

  bool alive(int ch, int n) const { return held[ch][n] || pedalled[ch][n]; }
  void prune(int ch) {
    auto &o = order[ch];
    o.erase(std::remove_if(o.begin(), o.end(), [&](uint8_t n) { return !alive(ch, n); }), o.end());
  }
  void key_up(int ch, int n) {
    if (!held[ch][n]) return;
    held[ch][n] = false;
    if (pedal[ch]) pedalled[ch][n] = true;
    prune(ch);
  }
  void apply(const MidiEvent &e) {
    const int ch = e.status & 0x0F, type = e.status & 0xF0;
    if (type == kMidiNoteOn && e.data2 > 0) {
      held[ch][e.data1] = true;
      pedalled[ch][e.data1] = false;
      auto &o = order[ch];
      o.erase(std::remove(o.begin(), o.end(), e.data1), o.end());
      o.push_back(e.data1);
    } else if (type == kMidiNoteOff || type == kMidiNoteOn) {
      key_up(ch, e.data1);
    } else if (type == kMidiControlChange) {
      const bool lift = (e.data1 == kCcSustain && e.data2 < 64) || e.data1 == kCcResetAllControllers;
      if (e.data1 == kCcSustain && e.data2 >= 64) pedal[ch] = true;
      if (lift) {
        pedal[ch] = false;
        for (auto &p : pedalled[ch]) p = false;
        prune(ch);
      }
      if (e.data1 == kCcAllNotesOff)
        for (int n = 0; n < 128; ++n) key_up(ch, n);
      if (e.data1 == kCcAllSoundOff) {
        for (int n = 0; n < 128; ++n) held[ch][n] = pedalled[ch][n] = false;
        prune(ch);
      }
    }
  }
};

MidiEvent random_event(std::mt19937 &rng) {
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  const auto ch = static_cast<uint8_t>(pick(0, 3));
  const auto note = static_cast<uint8_t>(pick(48, 66));  // a narrow band: many repeats
  const int kind = pick(0, 99);
  if (kind < 42) return note_on(ch, note, static_cast<uint8_t>(pick(1, 127)));
  if (kind < 70) return note_off(ch, note);
  if (kind < 78) return note_on(ch, note, 0);
  if (kind < 87) return control_change(ch, kCcSustain, static_cast<uint8_t>(pick(0, 127)));
  if (kind < 94) return pitch_bend(ch, static_cast<uint16_t>(pick(0, 16383)));
  if (kind < 96) return control_change(ch, kCcAllNotesOff, 0);
  if (kind < 97) return control_change(ch, kCcAllSoundOff, 0);
  if (kind < 98) return control_change(ch, kCcResetAllControllers, 0);
  // Bend range through RPN 0, one controller at a time, as a keyboard sends it.
  static const uint8_t rpn[] = {kCcRpnMsb, kCcRpnLsb, kCcDataEntryMsb, kCcDataEntryLsb};
  const uint8_t cc = rpn[pick(0, 3)];
  return control_change(ch, cc, static_cast<uint8_t>(cc >= kCcRpnLsb ? pick(0, 1) : pick(0, 12)));
}

// Four motors with uneven settings, so folding and mutes take part.
AllocatorConfig random_config(Policy policy, Priority priority) {
  AllocatorConfig c;
  c.motor_count = 4;
  c.policy = policy;
  c.priority = priority;
  c.motors[1].lowest_note = 48;
  c.motors[1].highest_note = 60;
  c.motors[1].muted[55] = true;  // G has no other octave in range: motor 1 never plays G
  c.motors[2].transpose = -12;
  c.motors[2].tuning_cents = 7.5;
  c.motors[3].muted[52] = true;
  c.mono_channel = {0, 0, 1, 2};  // channel 3 has no group
  for (size_t m = 4; m < c.mono_channel.size(); ++m) c.mono_channel[m] = -1;
  return c;
}
}  // namespace

TEST_CASE("random play keeps every motor on one live note and ends silent") {
  struct Row {
    Policy policy;
    Priority priority;
    uint32_t seed;
  };
  const Row row = GENERATE(Row{Policy::kPoly, Priority::kOldest, 1}, Row{Policy::kPoly, Priority::kLowest, 2},
                           Row{Policy::kPoly, Priority::kHighest, 3}, Row{Policy::kMono, Priority::kOldest, 4},
                           Row{Policy::kChannel, Priority::kOldest, 5});
  INFO("policy " << int(row.policy) << " priority " << int(row.priority) << " seed " << row.seed);
  const AllocatorConfig config = random_config(row.policy, row.priority);
  Rig r(config);
  KeyModel keys;
  std::mt19937 rng(row.seed);
  size_t max_sounding = 0, doubled = 0;

  auto check_state = [&](int step) {
    INFO("step " << step);
    std::map<std::pair<int, int>, int> taken;  // kPoly: each key's own motor's played note
    std::vector<MotorState> doublers;
    for (size_t m = 0; m < r.a.motor_count(); ++m) {
      const MotorState s = r.a.motor(m);
      INFO("motor " << m << " ch " << int(s.channel) << " note " << int(s.note));
      // What the boards were told is what the allocator says the motor plays.
      REQUIRE(r.board[m] == s.period_q8);
      if (!s.sounding) {
        REQUIRE(s.period_q8 == 0);
        continue;
      }
      // A sounding motor plays one live key, flagged as the model says.
      REQUIRE(keys.alive(s.channel, s.note));
      REQUIRE(s.held == keys.held[s.channel][s.note]);
      REQUIRE(s.sustained == !s.held);
      const MotorConfig &mc = config.motors[m];
      REQUIRE(s.played_note >= mc.lowest_note);
      REQUIRE(s.played_note <= mc.highest_note);
      REQUIRE_FALSE(mc.muted[s.played_note]);
      REQUIRE((s.played_note - s.note - mc.transpose) % 12 == 0);
      REQUIRE(s.period_q8 == expected_period(s.played_note, r.a.bend_semitones(s.channel), mc.tuning_cents));
      if (row.policy == Policy::kPoly) {
        if (s.doubling) doublers.push_back(s);
        else REQUIRE(taken.emplace(std::make_pair(s.channel, s.note), s.played_note).second);  // one own motor a key
      } else {
        REQUIRE_FALSE(s.doubling);
        // Mono and channel: the group follows the newest live key of its channel.
        const int owner = row.policy == Policy::kChannel ? int(m) : config.mono_channel[m];
        REQUIRE(s.channel == owner);
        REQUIRE(!keys.order[owner].empty());
        REQUIRE(s.note == keys.order[owner].back());
      }
    }
    // A doubler plays its key's very note, in unison with the key's own motor; two at most a key.
    std::map<std::pair<int, int>, int> doublers_of;
    for (const MotorState &s : doublers) {
      INFO("doubler of ch " << int(s.channel) << " note " << int(s.note));
      const auto key = std::make_pair(int(s.channel), int(s.note));
      REQUIRE(taken.count(key) == 1);
      REQUIRE(taken[key] == s.played_note);
      REQUIRE(++doublers_of[key] <= 2);
    }
    doubled += doublers.size();
    if (row.policy != Policy::kPoly) {
      // Motor 0 (full range, no mutes) sounds whenever its channel has a live key.
      REQUIRE(r.a.motor(0).sounding == !keys.order[0].empty());
    }
  };

  for (int step = 0; step < 10000; ++step) {
    const MidiEvent e = random_event(rng);
    std::vector<uint32_t> before = r.board;
    const auto out = r.send(e);
    for (const auto &p : out) REQUIRE(before[p.motor] != p.period_q8);  // only real changes
    keys.apply(e);
    check_state(step);
    max_sounding = std::max(max_sounding, r.sounding());
  }
  CHECK(max_sounding >= 3);  // the run did exercise polyphony
  CHECK((doubled > 0) == (row.policy == Policy::kPoly));  // and, in poly, doubling

  for (uint8_t ch = 0; ch < 16; ++ch) {
    r.cc(ch, kCcAllNotesOff, 0);
    r.cc(ch, kCcSustain, 0);
  }
  CHECK(r.all_silent());
}

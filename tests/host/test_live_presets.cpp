// test_live_presets.cpp: program-change presets in the live engine on a fake link: the first is
// active at start, a program change switches within the engine cycle (what sounded gets a silent
// entry, the next note plays the new preset), an unknown program changes nothing, bank select
// picks between presets, and without presets a program change still selects drum kits.
#include <catch2/catch.hpp>

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "core/pitch.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

constexpr uint8_t kSoft = 64;  // one motor a note
const uint32_t kF = 16000000;
const int kNoRefresh = 3600 * 1000;  // ms: no state refresh while a test checks exact frames

MidiEvent program_change(uint8_t ch, uint8_t program) {
  return MidiEvent{static_cast<uint8_t>(kMidiProgramChange | ch), program, 0, monotonic_us()};
}

// "plain" (program 1): four motors, no transpose. "split" (program 2): +12, keys below 60 on
// motors 0-1, 60 and above on 2-3. "bank 5" (program 2 in bank 5): motor 3 alone.
std::vector<LivePreset> three_presets(const AllocatorConfig &pool) {
  LivePreset plain{"plain", 0, -1, pool}, split{"split", 1, -1, pool}, banked{"bank 5", 1, 5, pool};
  split.config.transpose = 12;
  split.config.zone_count = 2;
  split.config.zones[0] = Zone{0, 59, -1, 0b0011};
  split.config.zones[1] = Zone{60, 127, -1, 0b1100};
  banked.config.zone_count = 1;
  banked.config.zones[0] = Zone{0, 127, -1, 0b1000};
  return {plain, split, banked};
}

}  // namespace

TEST_CASE("live: presets: a program change switches in the engine cycle, releasing what sounded", "[live]") {
  FakeLink link;
  const AllocatorConfig pool = pool_config({{&link, 4, kF}}, Policy::kPoly);
  LiveSession s({{&link, 4, kF}}, pool, kNoRefresh);
  s.set_presets(three_presets(pool));
  CHECK(s.preset() == 0);
  s.start();
  auto send = [&](const MidiEvent &e) { REQUIRE(s.midi_queue().try_enqueue(e)); };
  // Waits until motor m's frame with `note` reached the link (the writer coalesces what it has
  // not sent yet, so each phase waits for its frames before the next changes them).
  auto on_link = [&](uint8_t m, int note) {
    return eventually([&] {
      const auto p = periods_of(entries_of(link.frames()), m);
      return std::find(p.begin(), p.end(), hz_to_period_q8(note_hz(note), kF)) != p.end();
    });
  };
  send(note_on(0, 72, kSoft, monotonic_us()));  // plain: motor 0, untransposed
  send(note_on(0, 69, kSoft, monotonic_us()));  // held across the switch: motor 1
  REQUIRE(on_link(0, 72));
  REQUIRE(on_link(1, 69));
  send(note_off(0, 72, 0, monotonic_us()));
  send(program_change(3, 99));  // no preset has program 100: nothing changes
  send(program_change(0, 1));   // "split"
  send(note_on(0, 64, kSoft, monotonic_us()));
  REQUIRE(on_link(2, 76));
  CHECK(s.motor_note(2) == 76);
  CHECK(s.preset() == 1);
  send(note_off(0, 69, 0, monotonic_us()));  // the held key comes up after the switch: nothing to do
  send(note_on(0, 50, kSoft, monotonic_us()));
  REQUIRE(on_link(0, 62));
  send(control_change(0, kCcBankSelectMsb, 0));
  send(control_change(0, kCcBankSelectLsb, 5));
  send(program_change(0, 1));  // program 2 in bank 5: "bank 5", which plays on motor 3 alone
  send(note_on(0, 50, kSoft, monotonic_us()));
  REQUIRE(on_link(3, 50));
  CHECK(s.motor_note(3) == 50);
  CHECK(s.preset() == 2);
  CHECK(s.motor_note(0) == -1);
  CHECK(s.motor_note(2) == -1);
  s.stop();
  const auto entries = entries_of(link.frames());
  const uint32_t c5 = hz_to_period_q8(note_hz(72), kF), a4 = hz_to_period_q8(note_hz(69), kF);
  CHECK(periods_of(entries, 0) ==
        std::vector<uint32_t>{c5, 0, hz_to_period_q8(note_hz(62), kF), 0});
  // The held A4 was silenced at the switch, before the split's first note sounded, and only once.
  CHECK(periods_of(entries, 1) == std::vector<uint32_t>{a4, 0});
  CHECK(periods_of(entries, 2) == std::vector<uint32_t>{hz_to_period_q8(note_hz(76), kF), 0});
  CHECK(periods_of(entries, 3) == std::vector<uint32_t>{hz_to_period_q8(note_hz(50), kF), 0});
  size_t silence_1 = 0, e6 = 0;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (entries[i].motor == 1 && entries[i].period_q8 == 0) silence_1 = i;
    if (entries[i].motor == 2 && entries[i].period_q8 != 0) e6 = i;
  }
  CHECK(silence_1 < e6);
}

TEST_CASE("live: presets: with none, a program change still selects a drum kit, and bad presets are refused", "[live]") {
  FakeLink link;
  const AllocatorConfig pool = pool_config({{&link, 4, kF}}, Policy::kPoly);
  LiveSession s({{&link, 4, kF}}, pool, kNoRefresh);
  CHECK(s.preset() == -1);
  std::vector<LivePreset> wrong = three_presets(pool);
  wrong[1].config.motor_count = 3;
  CHECK_THROWS_AS(s.set_presets(wrong), std::invalid_argument);
  wrong = three_presets(pool);
  wrong[2].config.zones[0].motors = 0;
  CHECK_THROWS_AS(s.set_presets(wrong), std::invalid_argument);
  CHECK(s.preset() == -1);
  s.start();
  REQUIRE(s.midi_queue().try_enqueue(control_change(2, kCcBankSelectMsb, kBankGm2Rhythm)));
  REQUIRE(s.midi_queue().try_enqueue(program_change(2, 0)));  // channel 3 is a drum kit now
  REQUIRE(s.midi_queue().try_enqueue(note_on(2, 60, kSoft, monotonic_us())));
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 62, kSoft, monotonic_us())));
  REQUIRE(eventually([&] { return s.motor_note(0) == 62; }));
  CHECK(s.motor_note(1) == -1);  // the drum hit took no motor
  s.stop();
}

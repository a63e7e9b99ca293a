// test_allocator.cpp: the note-to-motor allocation engine, rule by rule, then under random play.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <new>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "core/midi_event.h"
#include "core/pitch.h"
#include "live/allocator.h"

using namespace stepchoir;

// Every heap allocation of this test program is counted, so a test can show the engine makes
// none.
namespace {
size_t g_allocations = 0;
}  // namespace
void *operator new(size_t n) {
  ++g_allocations;
  if (void *p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void *operator new(size_t n, const std::nothrow_t &) noexcept {
  ++g_allocations;
  return std::malloc(n ? n : 1);
}
void *operator new[](size_t n) { return operator new(n); }
void *operator new[](size_t n, const std::nothrow_t &t) noexcept { return operator new(n, t); }
// Every form of delete frees what the forms of new above took (a sanitizer checks they match).
void operator delete(void *p) noexcept { std::free(p); }
void operator delete(void *p, size_t) noexcept { std::free(p); }
void operator delete(void *p, const std::nothrow_t &) noexcept { std::free(p); }
void operator delete[](void *p) noexcept { std::free(p); }
void operator delete[](void *p, size_t) noexcept { std::free(p); }
void operator delete[](void *p, const std::nothrow_t &) noexcept { std::free(p); }

namespace {

constexpr uint32_t kF = 16000000;

// The period a motor must report for a played note, bend and tuning: the formula of the spec,
// written out independently of the allocator.
uint32_t expected_period(int played, double bend = 0.0, double cents = 0.0, double a4 = kA4Hz,
                         uint32_t f_cpu = kF) {
  return hz_to_period_q8(note_hz(played + bend + cents / 100.0, a4), f_cpu);
}

AllocatorConfig poly(uint8_t motors, Priority priority = Priority::kOldest) {
  AllocatorConfig c;
  c.motor_count = motors;
  c.policy = Policy::kPoly;
  c.priority = priority;
  return c;
}

// An Allocator plus a mirror of what the boards would play, built only from handle()'s output.
struct Rig {
  explicit Rig(const AllocatorConfig &c) : a(c), board(Allocator::kMaxMotors, 0) {}

  // Sends one event; returns the entries it produced (and applies them to the mirror).
  std::vector<sc::PeriodEntry> send(const MidiEvent &e) {
    std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
    out.resize(a.handle(e, out.data(), out.size()));
    for (const auto &p : out) board[p.motor] = p.period_q8;
    return out;
  }
  std::vector<sc::PeriodEntry> on(uint8_t ch, uint8_t note) { return send(note_on(ch, note, 100)); }
  std::vector<sc::PeriodEntry> off(uint8_t ch, uint8_t note) { return send(note_off(ch, note)); }
  std::vector<sc::PeriodEntry> cc(uint8_t ch, uint8_t n, uint8_t v) { return send(control_change(ch, n, v)); }
  std::vector<sc::PeriodEntry> bend(uint8_t ch, uint16_t v) { return send(pitch_bend(ch, v)); }

  // Motors sounding a given key of a channel.
  std::vector<size_t> motors_on(uint8_t ch, uint8_t note) const {
    std::vector<size_t> r;
    for (size_t m = 0; m < a.motor_count(); ++m) {
      const MotorState s = a.motor(m);
      if (s.sounding && s.channel == ch && s.note == note) r.push_back(m);
    }
    return r;
  }
  size_t sounding() const {
    size_t n = 0;
    for (size_t m = 0; m < a.motor_count(); ++m) n += a.motor(m).sounding;
    return n;
  }
  bool all_silent() const {
    for (size_t m = 0; m < Allocator::kMaxMotors; ++m)
      if (board[m] != 0 || (m < a.motor_count() && (a.motor(m).sounding || a.motor(m).period_q8)))
        return false;
    return true;
  }

  Allocator a;
  std::vector<uint32_t> board;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Poly: chords and the plain note rules
// ---------------------------------------------------------------------------------------------

TEST_CASE("poly chord takes one motor per note at the exact periods") {
  Rig r(poly(4));
  const std::vector<uint8_t> chord = {60, 64, 67};
  for (uint8_t n : chord) {
    const auto out = r.on(0, n);
    REQUIRE(out.size() == 1);  // exactly the one motor that changed
    CHECK(out[0].period_q8 == expected_period(n));
  }
  std::set<size_t> used;
  for (uint8_t n : chord) {
    const auto ms = r.motors_on(0, n);
    REQUIRE(ms.size() == 1);
    used.insert(ms[0]);
    CHECK(r.board[ms[0]] == expected_period(n));
    CHECK(r.a.motor(ms[0]).held);
  }
  CHECK(used.size() == 3);
  CHECK(r.sounding() == 3);
  for (uint8_t n : chord) r.off(0, n);
  CHECK(r.all_silent());
}

TEST_CASE("note-on with velocity 0 is a note-off") {
  Rig r(poly(2));
  r.on(0, 60);
  const auto out = r.send(note_on(0, 60, 0));
  REQUIRE(out.size() == 1);
  CHECK(out[0].period_q8 == sc::kPeriodSilent);
  CHECK(r.all_silent());
  // And a velocity-0 note-on for a key that is not down starts nothing.
  CHECK(r.send(note_on(0, 62, 0)).empty());
  CHECK(r.sounding() == 0);
}

TEST_CASE("repeated notes on one channel do not leak motors") {
  SECTION("poly") {
    Rig r(poly(4));
    for (int i = 0; i < 5; ++i) r.on(0, 60);
    CHECK(r.motors_on(0, 60).size() == 1);
    CHECK(r.sounding() == 1);
    r.off(0, 60);  // one note-off ends it
    CHECK(r.all_silent());
  }
  SECTION("poly under the pedal") {
    Rig r(poly(4));
    r.cc(0, kCcSustain, 127);
    for (int i = 0; i < 5; ++i) {
      r.on(0, 60);
      r.off(0, 60);
    }
    CHECK(r.sounding() == 1);
    r.cc(0, kCcSustain, 0);
    CHECK(r.all_silent());
  }
  SECTION("mono") {
    AllocatorConfig c;
    c.motor_count = 2;
    c.policy = Policy::kMono;
    c.mono_channel[0] = 0;
    Rig r(c);
    for (int i = 0; i < 5; ++i) r.on(0, 60);
    r.off(0, 60);
    CHECK(r.all_silent());
  }
}

TEST_CASE("note-off releases only its own channel and note") {
  Rig r(poly(4));
  r.on(0, 60);
  r.on(1, 60);  // same key on another channel: a motor of its own
  REQUIRE(r.motors_on(0, 60).size() == 1);
  REQUIRE(r.motors_on(1, 60).size() == 1);
  CHECK(r.off(2, 60).empty());  // wrong channel
  CHECK(r.off(0, 61).empty());  // wrong note
  CHECK(r.sounding() == 2);
  const size_t m1 = r.motors_on(1, 60)[0];
  const auto out = r.off(0, 60);
  REQUIRE(out.size() == 1);
  CHECK(out[0].motor != m1);
  CHECK(r.motors_on(0, 60).empty());
  CHECK(r.motors_on(1, 60).size() == 1);
}

TEST_CASE("events that are no channel voice message change nothing") {
  Rig r(poly(2));
  r.on(0, 60);
  const std::vector<MidiEvent> junk = {
      {0xF8, 0, 0, 0},           // clock
      {0x3C, 64, 0, 0},          // a data byte as status
      {0xC0, 5, 0, 0},           // program change
      {0xD0, 100, 0, 0},         // channel pressure
      {0x90, 200, 100, 0},       // note out of range
      {0x80, 60, 200, 0},        // velocity out of range: not a valid message
      {0xB0, kCcAllSoundOff, 128, 0},
  };
  for (const auto &e : junk) {
    INFO("status " << int(e.status));
    CHECK(r.send(e).empty());
    CHECK(r.motors_on(0, 60).size() == 1);
  }
}

// ---------------------------------------------------------------------------------------------
// Poly: stealing
// ---------------------------------------------------------------------------------------------

TEST_CASE("poly stealing follows the priority setting") {
  struct Row {
    Priority priority;
    uint8_t new_note;
    int lost;  // the note whose motor the new one takes, or -1 when the new note is refused
  };
  // Three motors play 60 (oldest) then 67 then 64 (newest).
  const std::vector<Row> rows = {
      {Priority::kOldest, 72, 60}, {Priority::kOldest, 55, 60},
      {Priority::kLowest, 72, -1}, {Priority::kLowest, 55, 67}, {Priority::kLowest, 66, 67},
      {Priority::kHighest, 72, 60}, {Priority::kHighest, 55, -1}, {Priority::kHighest, 62, 60},
  };
  for (const Row &row : rows) {
    INFO("priority " << int(row.priority) << " new note " << int(row.new_note));
    Rig r(poly(3, row.priority));
    for (uint8_t n : {60, 67, 64}) r.on(0, n);
    std::map<uint8_t, size_t> motor_of;
    for (uint8_t n : {60, 67, 64}) motor_of[n] = r.motors_on(0, n).at(0);
    const auto out = r.on(0, row.new_note);
    if (row.lost < 0) {
      CHECK(out.empty());
      CHECK(r.motors_on(0, row.new_note).empty());
      CHECK(r.sounding() == 3);
      continue;
    }
    REQUIRE(out.size() == 1);
    CHECK(out[0].motor == motor_of[static_cast<uint8_t>(row.lost)]);
    CHECK(out[0].period_q8 == expected_period(row.new_note));
    CHECK(r.motors_on(0, static_cast<uint8_t>(row.lost)).empty());
    CHECK(r.motors_on(0, row.new_note).size() == 1);
    // The stolen note is forgotten: its note-off does nothing to the new note.
    CHECK(r.off(0, static_cast<uint8_t>(row.lost)).empty());
    CHECK(r.sounding() == 3);
  }
}

TEST_CASE("poly oldest stealing counts a re-struck note as new") {
  Rig r(poly(3, Priority::kOldest));
  for (uint8_t n : {60, 64, 67}) r.on(0, n);
  r.on(0, 60);  // struck again: now the newest
  const size_t m64 = r.motors_on(0, 64).at(0);
  const auto out = r.on(0, 72);
  REQUIRE(out.size() == 1);
  CHECK(out[0].motor == m64);
  CHECK(r.motors_on(0, 60).size() == 1);
}

TEST_CASE("poly reuses a motor freed by a note-off before stealing") {
  Rig r(poly(2));
  r.on(0, 60);
  r.on(0, 64);
  const size_t m60 = r.motors_on(0, 60).at(0);
  r.off(0, 60);
  r.on(0, 67);
  CHECK(r.motors_on(0, 67).at(0) == m60);
  CHECK(r.motors_on(0, 64).size() == 1);
}

// ---------------------------------------------------------------------------------------------
// Sustain pedal
// ---------------------------------------------------------------------------------------------

TEST_CASE("sustain pedal holds released notes until it goes up") {
  Rig r(poly(4));
  r.on(0, 60);
  r.on(0, 64);
  r.cc(0, kCcSustain, 64);  // 64 is down
  CHECK(r.a.sustain(0));
  CHECK(r.off(0, 60).empty());
  CHECK(r.off(0, 64).empty());
  r.on(0, 67);  // pressed under the pedal and still down when it lifts
  for (uint8_t n : {60, 64}) {
    REQUIRE(r.motors_on(0, n).size() == 1);
    const MotorState s = r.a.motor(r.motors_on(0, n)[0]);
    CHECK(s.sustained);
    CHECK_FALSE(s.held);
  }
  CHECK(r.cc(1, kCcSustain, 0).empty());  // another channel's pedal releases nothing here
  const auto out = r.cc(0, kCcSustain, 63);  // 63 is up
  CHECK_FALSE(r.a.sustain(0));
  CHECK(out.size() == 2);
  for (const auto &p : out) CHECK(p.period_q8 == sc::kPeriodSilent);
  CHECK(r.motors_on(0, 60).empty());
  CHECK(r.motors_on(0, 64).empty());
  REQUIRE(r.motors_on(0, 67).size() == 1);
  CHECK(r.a.motor(r.motors_on(0, 67)[0]).held);
  r.off(0, 67);
  CHECK(r.all_silent());
}

TEST_CASE("a note struck again under the pedal keeps its motor and outlives the pedal") {
  Rig r(poly(4));
  r.on(0, 60);
  const size_t m = r.motors_on(0, 60).at(0);
  r.cc(0, kCcSustain, 127);
  r.off(0, 60);
  CHECK(r.on(0, 60).empty());  // same motor, same period: nothing to send
  REQUIRE(r.motors_on(0, 60).size() == 1);
  CHECK(r.motors_on(0, 60)[0] == m);
  CHECK(r.a.motor(m).held);
  CHECK_FALSE(r.a.motor(m).sustained);
  CHECK(r.cc(0, kCcSustain, 0).empty());  // the key is down again: the pedal lifts, it sounds on
  CHECK(r.a.motor(m).sounding);
  r.off(0, 60);
  CHECK(r.all_silent());
}

// ---------------------------------------------------------------------------------------------
// Mono and channel policies
// ---------------------------------------------------------------------------------------------

namespace {
// Motors 0 and 1 are channel 0's group, motor 2 is channel 1's, motor 3 belongs to nobody.
AllocatorConfig mono_config() {
  AllocatorConfig c;
  c.motor_count = 4;
  c.policy = Policy::kMono;
  c.mono_channel[0] = 0;
  c.mono_channel[1] = 0;
  c.mono_channel[2] = 1;
  return c;
}
}  // namespace

TEST_CASE("mono plays the last key in unison and returns to keys still held") {
  Rig r(mono_config());
  auto expect_group_plays = [&](int note) {
    for (size_t m : {0, 1}) {
      INFO("motor " << m << " note " << note);
      CHECK(r.board[m] == (note < 0 ? 0u : expected_period(note)));
      CHECK(r.a.motor(m).sounding == (note >= 0));
      if (note >= 0) CHECK(r.a.motor(m).note == note);
    }
    CHECK(r.board[2] == 0);
    CHECK(r.board[3] == 0);
  };
  r.on(0, 60);
  expect_group_plays(60);
  r.on(0, 64);
  expect_group_plays(64);
  r.on(0, 67);
  expect_group_plays(67);
  // Legato return: straight to the next held key, no silence in between.
  auto out = r.off(0, 67);
  REQUIRE(out.size() == 2);
  for (const auto &p : out) CHECK(p.period_q8 == expected_period(64));
  expect_group_plays(64);
  CHECK(r.off(0, 60).empty());  // a key below the top: nothing audible changes
  expect_group_plays(64);
  r.off(0, 64);
  expect_group_plays(-1);
  CHECK(r.all_silent());
}

TEST_CASE("mono groups keep to their channel") {
  Rig r(mono_config());
  r.on(0, 60);
  r.on(1, 48);
  r.on(2, 72);  // channel 2 has no group
  CHECK(r.a.motor(0).note == 60);
  CHECK(r.a.motor(1).note == 60);
  CHECK(r.a.motor(2).note == 48);
  CHECK(r.a.motor(2).channel == 1);
  CHECK_FALSE(r.a.motor(3).sounding);
  r.off(1, 60);  // wrong channel
  CHECK(r.a.motor(0).sounding);
  r.off(0, 60);
  CHECK_FALSE(r.a.motor(0).sounding);
  CHECK(r.a.motor(2).sounding);
}

TEST_CASE("mono with the pedal remembers released keys until it lifts") {
  Rig r(mono_config());
  r.on(0, 60);
  r.cc(0, kCcSustain, 127);
  r.on(0, 64);
  r.off(0, 64);
  CHECK(r.a.motor(0).note == 64);
  CHECK(r.a.motor(0).sustained);
  r.cc(0, kCcSustain, 0);  // 64 ends, 60 is still down
  CHECK(r.a.motor(0).note == 60);
  CHECK(r.a.motor(0).held);
  CHECK(r.board[0] == expected_period(60));
  r.cc(0, kCcSustain, 127);
  r.off(0, 60);
  CHECK(r.a.motor(0).sounding);
  r.cc(0, kCcSustain, 0);
  CHECK(r.all_silent());
}

TEST_CASE("channel policy puts channel n on motor n") {
  AllocatorConfig c;
  c.motor_count = 3;
  c.policy = Policy::kChannel;
  Rig r(c);
  for (uint8_t ch = 0; ch < 3; ++ch) {
    const auto out = r.on(ch, static_cast<uint8_t>(60 + ch));
    REQUIRE(out.size() == 1);
    CHECK(out[0].motor == ch);
    CHECK(out[0].period_q8 == expected_period(60 + ch));
  }
  CHECK(r.on(3, 70).empty());  // no motor 3
  CHECK(r.on(0, 72).size() == 1);  // motor 0 moves to the newer key
  CHECK(r.a.motor(0).note == 72);
  r.off(0, 72);
  CHECK(r.a.motor(0).note == 60);  // and comes back to the key still held
  CHECK(r.a.motor(1).note == 61);
  r.off(0, 60);
  CHECK_FALSE(r.a.motor(0).sounding);
}

// ---------------------------------------------------------------------------------------------
// Pitch bend and controllers
// ---------------------------------------------------------------------------------------------

TEST_CASE("pitch bend moves every sounding note of its channel only") {
  Rig r(poly(4));
  r.on(0, 60);
  r.on(0, 67);
  r.on(1, 64);
  const auto out = r.bend(0, 8192 + 4096);  // half way up the default +/-2: one semitone
  CHECK(out.size() == 2);
  CHECK(r.a.bend_semitones(0) == 1.0);
  CHECK(r.board[r.motors_on(0, 60).at(0)] == expected_period(60, 1.0));
  CHECK(r.board[r.motors_on(0, 67).at(0)] == expected_period(67, 1.0));
  CHECK(r.board[r.motors_on(1, 64).at(0)] == expected_period(64));
  r.on(0, 62);  // a note struck while bent starts bent
  CHECK(r.board[r.motors_on(0, 62).at(0)] == expected_period(62, 1.0));
  r.bend(0, 0);  // full down: -2
  CHECK(r.board[r.motors_on(0, 60).at(0)] == expected_period(60, -2.0));
  r.bend(0, 8192);
  CHECK(r.board[r.motors_on(0, 60).at(0)] == expected_period(60));
}

TEST_CASE("bend range follows RPN 0") {
  struct Row {
    uint8_t semitones, cents;
    double range;
  };
  const std::vector<Row> rows = {{12, 0, 12.0}, {1, 0, 1.0}, {2, 50, 2.5}, {0, 0, 0.0}};
  for (const Row &row : rows) {
    INFO("range " << row.range);
    Rig r(poly(2));
    r.on(0, 60);
    r.bend(0, 8192 + 4096);  // bent half way before the range changes: it retunes
    r.cc(0, kCcRpnMsb, 0);
    r.cc(0, kCcRpnLsb, 0);
    r.cc(0, kCcDataEntryMsb, row.semitones);
    r.cc(0, kCcDataEntryLsb, row.cents);
    CHECK(r.a.bend_range_semitones(0) == row.range);
    CHECK(r.board[0] == expected_period(60, row.range / 2));
    CHECK(r.a.bend_range_semitones(1) == 2.0);  // other channels keep theirs
  }
}

TEST_CASE("data entry without RPN 0 selected leaves the bend range alone") {
  Rig r(poly(2));
  r.cc(0, kCcDataEntryMsb, 12);  // nothing selected
  CHECK(r.a.bend_range_semitones(0) == 2.0);
  r.cc(0, kCcRpnMsb, 0);
  r.cc(0, kCcRpnLsb, 1);  // RPN 1: fine tuning, not honoured
  r.cc(0, kCcDataEntryMsb, 12);
  CHECK(r.a.bend_range_semitones(0) == 2.0);
  r.cc(0, kCcRpnLsb, 0);
  r.cc(0, kCcNrpnMsb, 0);  // an NRPN deselects the RPN
  r.cc(0, kCcDataEntryMsb, 12);
  CHECK(r.a.bend_range_semitones(0) == 2.0);
  r.cc(0, kCcRpnMsb, 0);
  r.cc(0, kCcRpnLsb, 0);
  r.cc(0, kCcDataEntryMsb, 12);
  CHECK(r.a.bend_range_semitones(0) == 12.0);
}

TEST_CASE("reset all controllers lifts the pedal and resets bend and bend range") {
  Rig r(poly(4));
  r.cc(0, kCcRpnMsb, 0);
  r.cc(0, kCcRpnLsb, 0);
  r.cc(0, kCcDataEntryMsb, 12);
  r.on(0, 60);
  r.on(0, 64);
  r.bend(0, 16383);
  r.cc(0, kCcSustain, 127);
  r.off(0, 60);  // held by the pedal
  r.cc(0, kCcResetAllControllers, 0);
  CHECK_FALSE(r.a.sustain(0));
  CHECK(r.a.bend_semitones(0) == 0.0);
  CHECK(r.a.bend_range_semitones(0) == 2.0);
  CHECK(r.motors_on(0, 60).empty());
  REQUIRE(r.motors_on(0, 64).size() == 1);
  CHECK(r.board[r.motors_on(0, 64)[0]] == expected_period(64));
  r.cc(0, kCcDataEntryMsb, 7);  // the RPN selection was reset too
  CHECK(r.a.bend_range_semitones(0) == 2.0);
}

TEST_CASE("all notes off respects the pedal and all sound off does not") {
  for (const bool pedal : {false, true}) {
    INFO("pedal " << pedal);
    Rig r(poly(4));
    r.on(0, 60);
    r.on(0, 64);
    r.on(1, 67);
    if (pedal) r.cc(0, kCcSustain, 127);
    r.cc(0, kCcAllNotesOff, 0);
    CHECK(r.motors_on(1, 67).size() == 1);  // another channel plays on
    CHECK(r.sounding() == (pedal ? 3u : 1u));
    r.cc(0, kCcSustain, 0);
    CHECK(r.sounding() == 1);
  }
  Rig r(poly(4));
  r.on(0, 60);
  r.cc(0, kCcSustain, 127);
  r.on(0, 64);
  r.off(0, 64);
  r.on(1, 67);
  const auto out = r.cc(0, kCcAllSoundOff, 0);
  CHECK(out.size() == 2);
  CHECK(r.sounding() == 1);
  CHECK(r.motors_on(1, 67).size() == 1);
  CHECK(r.off(0, 60).empty());  // forgotten: its late note-off does nothing
}

TEST_CASE("all notes off in mono keeps pedalled keys until the pedal lifts") {
  Rig r(mono_config());
  r.on(0, 60);
  r.on(0, 64);
  r.cc(0, kCcSustain, 127);
  r.cc(0, kCcAllNotesOff, 0);
  CHECK(r.a.motor(0).note == 64);
  CHECK(r.a.motor(0).sustained);
  r.cc(0, kCcSustain, 0);
  CHECK(r.all_silent());
}

// ---------------------------------------------------------------------------------------------
// Per-motor settings
// ---------------------------------------------------------------------------------------------

TEST_CASE("notes outside a motor's range fold by octaves into it") {
  struct Row {
    int transpose;
    uint8_t note;
    int played;
  };
  // Range 48..72 after transpose.
  const std::vector<Row> rows = {
      {0, 60, 60},  {0, 48, 48},  {0, 72, 72},  {0, 47, 59}, {0, 30, 54},
      {0, 73, 61},  {0, 84, 72},  {0, 100, 64}, {0, 0, 48},  {0, 127, 67},
      {12, 65, 65}, {-12, 50, 50}, {-24, 60, 48},
  };
  for (const Row &row : rows) {
    INFO("note " << int(row.note) << " transpose " << row.transpose);
    AllocatorConfig c = poly(1);
    c.motors[0].lowest_note = 48;
    c.motors[0].highest_note = 72;
    c.motors[0].transpose = static_cast<int8_t>(row.transpose);
    Rig r(c);
    r.on(0, row.note);
    CHECK(r.a.motor(0).played_note == row.played);
    CHECK(r.board[0] == expected_period(row.played));
  }
}

TEST_CASE("a range narrower than an octave refuses the notes it cannot reach") {
  AllocatorConfig c = poly(1);
  c.motors[0].lowest_note = 60;
  c.motors[0].highest_note = 64;
  Rig r(c);
  CHECK(r.on(0, 66).empty());
  CHECK(r.on(0, 76).size() == 1);
  CHECK(r.a.motor(0).played_note == 64);
}

TEST_CASE("muted notes go to another motor or fold to another octave") {
  SECTION("poly picks a motor that plays it unfolded") {
    AllocatorConfig c = poly(3);
    c.motors[0].muted[60] = true;
    c.motors[1].lowest_note = 62;  // would fold 60 up
    Rig r(c);
    r.on(0, 60);
    REQUIRE(r.motors_on(0, 60).size() == 1);
    CHECK(r.motors_on(0, 60)[0] == 2);
    CHECK(r.a.motor(2).played_note == 60);
  }
  SECTION("a lone motor folds a muted note to the nearest octave") {
    AllocatorConfig c = poly(1);
    c.motors[0].muted[60] = true;
    Rig r(c);
    r.on(0, 60);
    CHECK(r.a.motor(0).played_note == 48);  // lower octave first at equal distance
    r.off(0, 60);
    c.motors[0].muted[48] = true;
    REQUIRE(r.a.configure(c));
    r.on(0, 60);
    CHECK(r.a.motor(0).played_note == 72);
    CHECK(r.board[0] == expected_period(72));
  }
  SECTION("mutes apply after transpose") {
    AllocatorConfig c = poly(1);
    c.motors[0].transpose = 2;
    c.motors[0].muted[62] = true;
    Rig r(c);
    r.on(0, 60);
    CHECK(r.a.motor(0).played_note == 50);
  }
  SECTION("a note muted in every octave is refused") {
    AllocatorConfig c = poly(2);
    for (int n = 0; n < 128; n += 12) c.motors[0].muted[static_cast<size_t>(n)] = true;
    Rig r(c);
    r.on(0, 60);
    CHECK(r.motors_on(0, 60).at(0) == 1);
    r.on(0, 72);  // motor 0 is free but cannot play any C: 72 steals motor 1 instead
    CHECK(r.motors_on(0, 72).at(0) == 1);
    CHECK_FALSE(r.a.motor(0).sounding);
  }
  SECTION("mono folds a muted note on the motors that have it muted") {
    AllocatorConfig c = mono_config();
    c.motors[1].muted[60] = true;
    Rig r(c);
    r.on(0, 60);
    CHECK(r.a.motor(0).played_note == 60);
    CHECK(r.a.motor(1).played_note == 48);
  }
}

TEST_CASE("transpose tuning A4 and clock give exact periods") {
  struct Row {
    int transpose;
    double cents, a4;
    uint32_t f_cpu;
    uint8_t note;
  };
  const std::vector<Row> rows = {
      {0, 0.0, 440.0, kF, 69},        {3, 25.0, 440.0, kF, 60},    {-12, -50.0, 440.0, kF, 81},
      {0, 0.0, 432.0, kF, 69},        {7, 12.5, 415.0, kF, 57},    {0, 0.0, 440.0, 20000000, 60},
  };
  for (const Row &row : rows) {
    INFO("transpose " << row.transpose << " cents " << row.cents << " a4 " << row.a4);
    AllocatorConfig c = poly(1);
    c.a4_hz = row.a4;
    c.motors[0].transpose = static_cast<int8_t>(row.transpose);
    c.motors[0].tuning_cents = row.cents;
    c.motors[0].f_cpu_hz = row.f_cpu;
    Rig r(c);
    const auto out = r.on(0, row.note);
    REQUIRE(out.size() == 1);
    const int played = row.note + row.transpose;
    CHECK(out[0].period_q8 == expected_period(played, 0.0, row.cents, row.a4, row.f_cpu));
    // And independently of the helper: the frequency is within rounding of the formula.
    const double hz = row.a4 * std::exp2((played + row.cents / 100.0 - 69) / 12.0);
    CHECK(std::abs(period_q8_to_hz(out[0].period_q8, row.f_cpu) - hz) < hz * 1e-6);
  }
  // A4 itself at the default reference: 16 MHz * 256 / 440 Hz, rounded.
  Rig r(poly(1));
  r.on(0, 69);
  CHECK(r.board[0] == 9309091u);
}

TEST_CASE("changing A4 retunes the sounding motors") {
  Rig r(poly(2));
  r.on(0, 60);
  r.a.set_a4_hz(442.0);
  sc::PeriodEntry out[4];
  REQUIRE(r.a.flush(out, 4) == 1);
  CHECK(out[0].period_q8 == expected_period(60, 0.0, 0.0, 442.0));
  r.a.set_a4_hz(-1.0);  // ignored
  CHECK(r.a.config().a4_hz == 442.0);
}

// ---------------------------------------------------------------------------------------------
// Output plumbing, panic and configuration
// ---------------------------------------------------------------------------------------------

TEST_CASE("a short output buffer loses nothing") {
  Rig r(poly(4));
  for (uint8_t n : {60, 64, 67, 71}) r.on(0, n);
  r.cc(0, kCcSustain, 127);
  for (uint8_t n : {60, 64, 67, 71}) r.off(0, n);
  sc::PeriodEntry out[2];
  REQUIRE(r.a.handle(control_change(0, kCcSustain, 0), out, 2) == 2);
  CHECK(out[0].motor == 0);
  CHECK(out[1].motor == 1);
  REQUIRE(r.a.flush(out, 2) == 2);
  CHECK(out[0].motor == 2);
  CHECK(out[1].motor == 3);
  CHECK(r.a.flush(out, 2) == 0);
}

TEST_CASE("panic silences every motor and forgets every note") {
  Rig r(poly(3));
  r.on(0, 60);
  r.cc(0, kCcSustain, 127);
  r.on(1, 64);
  r.off(1, 64);
  sc::PeriodEntry out[8];
  REQUIRE(r.a.panic(out, 8) == 3);  // every motor, sounding or not
  for (size_t i = 0; i < 3; ++i) {
    CHECK(out[i].motor == i);
    CHECK(out[i].period_q8 == sc::kPeriodSilent);
    CHECK_FALSE(r.a.motor(i).sounding);
  }
  CHECK_FALSE(r.a.sustain(0));
  CHECK(r.off(0, 60).empty());
  r.on(0, 62);
  r.off(0, 62);  // the pedal is up after a panic: the note ends
  CHECK(r.sounding() == 0);
}

TEST_CASE("configuration is validated") {
  AllocatorConfig bad = poly(0);
  CHECK(Allocator::validate(bad) != nullptr);
  CHECK_THROWS_AS(Allocator(bad), std::invalid_argument);
  AllocatorConfig good = poly(2);
  CHECK(Allocator::validate(good) == nullptr);
  Allocator a(good);
  AllocatorConfig range = good;
  range.motors[1].lowest_note = 80;
  range.motors[1].highest_note = 70;
  CHECK_FALSE(a.configure(range));
  AllocatorConfig a4 = good;
  a4.a4_hz = 0;
  CHECK_FALSE(a.configure(a4));
  AllocatorConfig group = good;
  group.policy = Policy::kMono;
  group.mono_channel[0] = 16;
  CHECK_FALSE(a.configure(group));
  CHECK(a.config().policy == Policy::kPoly);
}

TEST_CASE("reconfiguring silences what was sounding") {
  Rig r(poly(4));
  r.on(0, 60);
  r.on(0, 64);
  AllocatorConfig c = poly(1);
  REQUIRE(r.a.configure(c));
  sc::PeriodEntry out[8];
  const size_t n = r.a.flush(out, 8);
  REQUIRE(n == 2);  // motor 1 is beyond the new count but was sounding
  for (size_t i = 0; i < n; ++i) {
    CHECK(out[i].period_q8 == sc::kPeriodSilent);
    r.board[out[i].motor] = out[i].period_q8;
  }
  CHECK(r.all_silent());
}

TEST_CASE("the engine never allocates after construction") {
  for (const Policy policy : {Policy::kPoly, Policy::kMono, Policy::kChannel}) {
    AllocatorConfig c = poly(4);
    c.policy = policy;
    c.mono_channel[0] = c.mono_channel[1] = 0;
    Allocator a(c);
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> byte(0, 127), kind(0, 3);
    sc::PeriodEntry out[Allocator::kMaxMotors];
    size_t entries = 0;
    const size_t before = g_allocations;
    for (int i = 0; i < 5000; ++i) {
      static const uint8_t status[] = {kMidiNoteOn, kMidiNoteOff, kMidiControlChange, kMidiPitchBend};
      const MidiEvent e{static_cast<uint8_t>(status[kind(rng)] | (i & 1)), static_cast<uint8_t>(byte(rng)),
                        static_cast<uint8_t>(byte(rng)), 0};
      entries += a.handle(e, out, Allocator::kMaxMotors);
    }
    entries += a.panic(out, Allocator::kMaxMotors);
    a.set_a4_hz(441.0);
    a.configure(c);
    entries += a.flush(out, Allocator::kMaxMotors);
    const size_t allocations = g_allocations - before;
    INFO("policy " << int(policy));
    CHECK(allocations == 0);
    CHECK(entries > 100);  // the events did make it play
  }
}

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
  size_t max_sounding = 0;

  auto check_state = [&](int step) {
    INFO("step " << step);
    std::set<std::pair<int, int>> taken;
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
        REQUIRE(taken.insert({s.channel, s.note}).second);  // no key on two motors
      } else {
        // Mono and channel: the group follows the newest live key of its channel.
        const int owner = row.policy == Policy::kChannel ? int(m) : config.mono_channel[m];
        REQUIRE(s.channel == owner);
        REQUIRE(!keys.order[owner].empty());
        REQUIRE(s.note == keys.order[owner].back());
      }
    }
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

  for (uint8_t ch = 0; ch < 16; ++ch) {
    r.cc(ch, kCcAllNotesOff, 0);
    r.cc(ch, kCcSustain, 0);
  }
  CHECK(r.all_silent());
}

TEST_CASE("a bend or tuning past what a board plays folds by octaves into its period range") {
  AllocatorConfig c = poly(1);
  c.motors[0].tuning_cents = 2400.0;  // two octaves up: C8 would be past 5 kHz
  Rig r(c);
  const auto out = r.on(0, 108);
  REQUIRE(out.size() == 1);
  CHECK(out[0].period_q8 >= sc::kPeriodQ8Min);
  CHECK(out[0].period_q8 <= sc::kPeriodQ8Max);
  // folded by whole octaves: the pitch class is kept
  const double hz = period_q8_to_hz(out[0].period_q8, kF);
  const double octaves = std::log2(hz / note_hz(108 + 24));
  CHECK(std::abs(octaves - std::round(octaves)) < 1e-6);
  CHECK(std::round(octaves) < 0);
}

TEST_CASE("percussion channels are not sung: channel 10, and a drum kit chosen by bank select") {
  Rig r(poly(4));
  auto program = [&](uint8_t ch, uint8_t bank) {
    r.cc(ch, kCcBankSelectMsb, bank);
    r.send(MidiEvent{static_cast<uint8_t>(kMidiProgramChange | ch), 0, 0, 0});
  };
  CHECK(r.on(kGmDrumChannel, 36).empty());  // a kick: no motor
  CHECK(r.sounding() == 0);
  CHECK(r.on(2, 60).size() == 1);
  // GM2: bank 120 makes channel 3 a drum kit at its program change; the note it holds is
  // still released by its note-off.
  program(2, kBankGm2Rhythm);
  CHECK(r.on(2, 38).empty());
  CHECK(r.off(2, 60).size() == 1);
  CHECK(r.sounding() == 0);
  // Bank 121 makes channel 10 melodic.
  program(kGmDrumChannel, kBankGm2Melody);
  CHECK(r.on(kGmDrumChannel, 64).size() == 1);
  // A bank select without a program change changes nothing.
  r.cc(kGmDrumChannel, kCcBankSelectMsb, kBankXgDrums);
  CHECK(r.on(kGmDrumChannel, 67).size() == 1);
  // A reset forgets the kits: channel 10 is drums again.
  AllocatorConfig c = poly(4);
  REQUIRE(r.a.configure(c));
  r.send(MidiEvent{kMidiControlChange, kCcAllSoundOff, 0, 0});
  CHECK(r.on(kGmDrumChannel, 36).empty());
  // sing_percussion: drum channels play pitches, as any channel.
  c.sing_percussion = true;
  REQUIRE(r.a.configure(c));
  CHECK(r.on(kGmDrumChannel, 36).size() == 1);
}

// ---------------------------------------------------------------------------------------------
// Vibrato (mod wheel, aftertouch)
// ---------------------------------------------------------------------------------------------

TEST_CASE("vibrato: the mod wheel adds a sine in pitch, depth linear in it, faded in, gone with the wheel") {
  AllocatorConfig c = poly(2);
  c.vibrato.rate_hz = 5.0;  // a quarter cycle every 50 ms
  c.vibrato.depth_cents = 50.0;
  c.vibrato.fade_ms = 100.0;
  Rig r(c);
  MidiEvent on = note_on(0, 69, 100);
  on.timestamp_us = 1000000;
  r.send(on);
  CHECK_FALSE(r.a.vibrating());
  MidiEvent wheel = control_change(0, kCcModWheel, 127);
  wheel.timestamp_us = 1000000;
  r.send(wheel);
  CHECK(r.a.vibrating());
  std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
  auto at = [&](uint64_t us) {  // the motor's period after a tick at 1 s + us
    out.resize(Allocator::kMaxMotors);
    out.resize(r.a.tick(1000000 + us, out.data(), out.size()));
    for (const auto &p : out) r.board[p.motor] = p.period_q8;
    return r.board[0];
  };
  CHECK(at(0) == expected_period(69));  // the sine starts at 0 with the note
  CHECK(at(25000) == expected_period(69, 0, 50.0 * 0.25 * std::sin(M_PI / 4)));  // fading in: a quarter
  CHECK(at(50000) == expected_period(69, 0, 50.0 * 0.5));                        // the peak, half faded in
  CHECK(at(150000) == expected_period(69, 0, -50.0));                            // the trough, full depth
  CHECK(at(200000) == expected_period(69));
  // half the wheel, half the depth
  MidiEvent half = control_change(0, kCcModWheel, 64);
  half.timestamp_us = 1250000;
  r.send(half);
  CHECK(r.board[0] == expected_period(69, 0, 50.0 * 64 / 127));
  // the wheel down: the note's own pitch, and no more ticks
  MidiEvent down = control_change(0, kCcModWheel, 0);
  down.timestamp_us = 1260000;
  r.send(down);
  CHECK(r.board[0] == expected_period(69));
  CHECK_FALSE(r.a.vibrating());
  // reset-all-controllers lowers the wheel too
  r.send(control_change(0, kCcModWheel, 127));
  CHECK(r.a.vibrating());
  r.send(control_change(0, kCcResetAllControllers, 0));
  CHECK_FALSE(r.a.vibrating());
}

TEST_CASE("vibrato: channel aftertouch sets the depth only when configured, and never allocates") {
  AllocatorConfig c = poly(2);
  Rig plain(c);
  plain.on(0, 60);
  plain.send(MidiEvent{static_cast<uint8_t>(kMidiChannelPressure | 0), 100, 0, 0});
  CHECK_FALSE(plain.a.vibrating());
  c.vibrato.aftertouch = true;
  Rig pressed(c);
  pressed.on(0, 60);
  pressed.send(MidiEvent{static_cast<uint8_t>(kMidiChannelPressure | 0), 100, 0, 0});
  CHECK(pressed.a.vibrating());
  sc::PeriodEntry out[Allocator::kMaxMotors];
  const size_t before = g_allocations;
  for (uint64_t t = 0; t < 1000000; t += kVibratoTickUs) pressed.a.tick(t, out, Allocator::kMaxMotors);
  CHECK(g_allocations == before);
}

TEST_CASE("glide: CC65 on, CC5 time: a motor's next note slides from its last at an even rate, then lands exactly") {
  Rig r(poly(2));
  auto at = [&](MidiEvent e, uint64_t us) {
    e.timestamp_us = us;
    r.send(e);
  };
  auto tick = [&](uint64_t us) {
    std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
    out.resize(r.a.tick(us, out.data(), out.size()));
    for (const auto &p : out) r.board[p.motor] = p.period_q8;
  };
  at(control_change(0, kCcPortamento, 127), 1000);
  at(control_change(0, kCcPortamentoTime, 20), 1000);  // 20 x 16 ms = 320 ms
  at(note_on(0, 57, 100), 1000000);
  CHECK(r.board[0] == expected_period(57));  // nothing played before: no glide
  at(note_off(0, 57), 1200000);
  at(note_on(0, 69, 100), 1250000);  // 50 ms after: the same motor slides up an octave
  REQUIRE(r.motors_on(0, 69) == std::vector<size_t>{0});
  CHECK(r.board[0] == expected_period(57));
  CHECK(r.a.vibrating());  // the engine ticks while it glides
  tick(1250000 + 160000);
  CHECK(r.board[0] == expected_period(63));  // half way: half the octave, evenly in cents
  tick(1250000 + 240000);
  CHECK(r.board[0] == expected_period(66));
  tick(1250000 + 320000);
  CHECK(r.board[0] == expected_period(69));  // landed exactly
  CHECK_FALSE(r.a.vibrating());
  // A motor silent for longer than kGlideAfterSilenceUs starts its note on pitch.
  at(note_off(0, 69), 2000000);
  at(note_on(0, 60, 100), 2000000 + kGlideAfterSilenceUs + 1000);
  CHECK(r.board[0] == expected_period(60));
  // Glide off: no slide.
  at(control_change(0, kCcPortamento, 0), 2500000);
  at(note_on(0, 72, 100), 2500000);
  CHECK(r.board[r.motors_on(0, 72).at(0)] == expected_period(72));
}

TEST_CASE("glide: in mono the channel's note always slides, even after a silence") {
  AllocatorConfig c;
  c.motor_count = 1;
  c.policy = Policy::kMono;
  c.mono_channel[0] = 0;
  Rig r(c);
  MidiEvent e = control_change(0, kCcPortamento, 127);
  r.send(e);
  r.send(control_change(0, kCcPortamentoTime, 10));  // 160 ms
  e = note_on(0, 60, 100);
  e.timestamp_us = 1000000;
  r.send(e);
  e = note_off(0, 60);
  e.timestamp_us = 1100000;
  r.send(e);
  e = note_on(0, 64, 100);
  e.timestamp_us = 3000000;  // two seconds of silence
  r.send(e);
  CHECK(r.board[0] == expected_period(60));
  std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
  out.resize(r.a.tick(3000000 + 80000, out.data(), out.size()));
  REQUIRE(out.size() == 1);
  CHECK(out[0].period_q8 == expected_period(62));
}

// test_allocator.cpp: the note-to-motor allocation engine: poly notes, stealing, the sustain pedal,
// mono and channel policies, output, panic and configuration; and the count of heap allocations.
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

#include "allocator_rig.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

// Every heap allocation of this test program is counted (allocator_rig.h).
size_t stepchoir::allocator_test::g_allocations = 0;
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
    Rig r(mono_on_motor_0(2));
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

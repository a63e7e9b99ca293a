// test_allocator_stage.cpp: the performer's stage controls on the Allocator: a stage transpose
// for new notes that outlasts a preset switch, stage mutes in poly and mono, a controller on
// every channel, and a vibrato rate change that keeps each note's sine continuous.
#include <catch2/catch.hpp>

#include <cmath>

#include "allocator_rig.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

TEST_CASE("allocator: the stage transpose moves new notes, keeps held ones and outlasts a preset",
          "[allocator][stage]") {
  Rig r(poly(3));
  r.on(0, 60);
  r.a.set_stage_transpose(12);
  CHECK(r.a.stage_transpose() == 12);
  r.on(0, 62);
  CHECK(r.board[0] == expected_period(60));  // held: its pitch stays
  CHECK(r.board[1] == expected_period(74));
  r.off(0, 60);  // the note-off still finds it by key
  CHECK(r.board[0] == 0);
  AllocatorConfig other = poly(3);
  other.transpose = 2;
  REQUIRE(r.a.configure(other));
  r.send(note_off(0, 62));  // forgotten by the switch: nothing
  r.on(0, 60);
  CHECK(r.board[0] == expected_period(74));  // preset +2, stage +12
  r.a.set_stage_transpose(-100);
  CHECK(r.a.stage_transpose() == -48);
}

TEST_CASE("allocator: a stage mute in poly silences the motor and hands the note to a doubler",
          "[allocator][stage]") {
  Rig r(poly(3));
  r.on(0, 60, 127);  // three motors in unison
  REQUIRE(r.motors_on(0, 60).size() == 3);
  r.a.set_stage_mutes(0b001);
  std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
  out.resize(r.a.flush(out.data(), out.size()));
  for (const auto &p : out) r.board[p.motor] = p.period_q8;
  CHECK(r.board[0] == 0);
  CHECK(r.board[1] == expected_period(60));
  CHECK(r.motors_on(0, 60).size() == 2);
  r.off(0, 60);
  CHECK(r.all_silent());
  r.on(0, 64);
  r.on(0, 67);
  r.on(0, 71);  // motor 0 is muted: two motors for three notes, the oldest stolen
  CHECK(r.board[0] == 0);
  CHECK(r.a.stage_mutes() == 0b001);
  AllocatorConfig same = poly(3);
  REQUIRE(r.a.configure(same));
  CHECK(r.a.stage_mutes() == 0b001);  // outlasts the switch
}

TEST_CASE("allocator: a stage mute in mono silences one motor of the group, unmuted it rejoins",
          "[allocator][stage]") {
  Rig r(mono_config());
  r.on(0, 57);
  REQUIRE(r.board[0] == expected_period(57));
  REQUIRE(r.board[1] == expected_period(57));
  auto flush = [&] {
    std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
    out.resize(r.a.flush(out.data(), out.size()));
    for (const auto &p : out) r.board[p.motor] = p.period_q8;
  };
  r.a.set_stage_mutes(0b010);
  flush();
  CHECK(r.board[1] == 0);
  r.on(0, 59);
  CHECK(r.board[0] == expected_period(59));
  CHECK(r.board[1] == 0);
  r.a.set_stage_mutes(0);
  flush();
  CHECK(r.board[1] == expected_period(59));
}

TEST_CASE("allocator: a controller sent to every channel", "[allocator][stage]") {
  Rig r(poly(2));
  r.a.control_all(kCcSustain, 127);
  for (uint8_t ch = 0; ch < 16; ++ch) CHECK(r.a.sustain(ch));
  r.a.control_all(kCcAllSoundOff, 0);  // channel mode messages are not stage knobs
  r.a.control_all(kCcSustain, 0);
  CHECK_FALSE(r.a.sustain(5));
}

TEST_CASE("allocator: a vibrato rate change keeps every note's sine where it is", "[allocator][stage]") {
  AllocatorConfig c = poly(2);
  c.vibrato.fade_ms = 0;
  Rig r(c);
  const uint64_t t0 = 1000000;
  r.at(control_change(0, kCcModWheel, 127), t0);
  r.at(note_on(0, 69, kSoft), t0);
  const uint64_t t1 = t0 + 123457;  // mid-cycle
  r.tick(t1);
  const uint32_t before = r.board[0];
  REQUIRE(before != expected_period(69));  // it vibrates
  r.a.set_vibrato_rate(9.0);
  r.tick(t1);  // the same moment: the same pitch
  CHECK(std::abs(int64_t(r.board[0]) - int64_t(before)) <= 1);
  // From there on, the new rate: the next zero crossing upwards comes 1/9 s after the last one.
  double last = 0, crossing = 0;
  for (uint64_t t = t1; t < t1 + 400000; t += 100) {
    r.tick(t);
    const double cents = 1200.0 * std::log2(double(expected_period(69)) / double(r.board[0]));
    if (last < 0 && cents >= 0) {
      if (crossing > 0) {
        CHECK((t - crossing) / 1e6 == Approx(1 / 9.0).epsilon(0.01));
        break;
      }
      crossing = double(t);
    }
    last = cents;
  }
  CHECK(crossing > 0);
  r.a.set_vibrato_rate(0);  // ignored
  CHECK(r.a.config().vibrato.rate_hz == 9.0);
}

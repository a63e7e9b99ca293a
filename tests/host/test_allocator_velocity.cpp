// test_allocator_velocity.cpp: velocity -> loudness: a loud kPoly note's extra motors in unison
// (the thresholds, free motors only, range and mutes, release with the note, taken before any
// note is stolen, following bend, vibrato and glide), and nothing of it in kMono and kChannel.
#include <catch2/catch.hpp>

#include <vector>

#include "allocator_rig.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

namespace {

AllocatorConfig poly_velocity(uint8_t motors, uint8_t double_at, uint8_t triple_at) {
  AllocatorConfig c = poly(motors);
  c.velocity.double_at = double_at;
  c.velocity.triple_at = triple_at;
  return c;
}

// The motors sounding a key, and whether each has the key's period.
std::vector<size_t> unison(const Rig &r, uint8_t ch, uint8_t note, uint32_t period) {
  const std::vector<size_t> motors = r.motors_on(ch, note);
  for (size_t m : motors) {
    INFO("motor " << m);
    CHECK(r.board[m] == period);
  }
  return motors;
}

}  // namespace

TEST_CASE("velocity: a note takes a second motor from double_at, a third from triple_at, each level off at 0 or above 127") {
  const VelocityConfig defaults;
  CHECK(defaults.double_at == 100);
  CHECK(defaults.triple_at == 120);
  struct Row {
    uint8_t double_at, triple_at, velocity;
    size_t motors;
  };
  const Row row = GENERATE(Row{100, 120, 1, 1}, Row{100, 120, 99, 1}, Row{100, 120, 100, 2}, Row{100, 120, 119, 2},
                           Row{100, 120, 120, 3}, Row{100, 120, 127, 3},
                           // levels off
                           Row{0, 120, 119, 1}, Row{0, 120, 120, 2}, Row{100, 0, 127, 2}, Row{0, 0, 127, 1},
                           Row{128, 255, 127, 1}, Row{100, 128, 127, 2},
                           // each threshold counts on its own
                           Row{120, 100, 110, 2}, Row{64, 64, 64, 3});
  INFO("double_at " << int(row.double_at) << " triple_at " << int(row.triple_at) << " velocity " << int(row.velocity));
  CHECK(VelocityConfig{row.double_at, row.triple_at}.extra_motors(row.velocity) == row.motors - 1);
  Rig r(poly_velocity(4, row.double_at, row.triple_at));
  const auto out = r.on(0, 60, row.velocity);
  CHECK(out.size() == row.motors);
  const std::vector<size_t> motors = unison(r, 0, 60, expected_period(60));
  CHECK(motors.size() == row.motors);
  CHECK(r.sounding() == row.motors);
  size_t doubling = 0;
  for (size_t m : motors) doubling += r.a.motor(m).doubling;
  CHECK(doubling == row.motors - 1);
  CHECK_FALSE(r.a.motor(motors.at(0)).doubling);  // the note's own motor: the lowest free one
  // Velocity 0 is a note-off, as ever: every motor of the note stops.
  r.send(note_on(0, 60, 0));
  CHECK(r.all_silent());
}

TEST_CASE("velocity: doublers are free motors only, never a sounding note's") {
  Rig r(poly(4));
  r.on(0, 60);
  r.on(0, 62);
  r.on(0, 64);
  // Three keys held: a loud fourth note gets the one free motor and no more.
  r.on(0, 67, 127);
  CHECK(r.motors_on(0, 67).size() == 1);
  for (uint8_t n : {60, 62, 64}) CHECK(unison(r, 0, n, expected_period(n)).size() == 1);
  // One free motor for a loud note: its own, and the next loud note finds none to double with.
  r.off(0, 62);
  r.off(0, 64);
  r.on(0, 69, 127);
  CHECK(unison(r, 0, 69, expected_period(69)).size() == 2);
  CHECK(r.sounding() == 4);
  r.off(0, 60);
  CHECK(unison(r, 0, 69, expected_period(69)).size() == 2);  // a doubler is not added later
}

TEST_CASE("velocity: doublers play the note's very pitch: their range, mutes and transpose decide, their tuning stays") {
  AllocatorConfig c = poly(6);
  c.motors[1].lowest_note = 40;  // 60 folds to 48 here: not in unison
  c.motors[1].highest_note = 50;
  c.motors[2].muted[60] = true;  // 60 moves to another octave here
  c.motors[3].transpose = 12;    // 60 plays 72 here
  c.motors[4].tuning_cents = 10.0;
  Rig r(c);
  r.on(0, 60, 127);
  REQUIRE(r.motors_on(0, 60) == std::vector<size_t>{0, 4, 5});
  CHECK(r.board[0] == expected_period(60));
  CHECK(r.board[4] == expected_period(60, 0, 10.0));  // its own tuning
  CHECK(r.board[5] == expected_period(60));
  for (size_t m : {4, 5}) CHECK(r.a.motor(m).played_note == 60);
  // A note none of the free motors plays in unison sounds alone.
  r.on(0, 61, 127);
  CHECK(r.motors_on(0, 61).size() == 1);

  // Unfolded motors first: motor 1 reaches 60 only by folding 48 up an octave.
  AllocatorConfig f = poly(3);
  f.motors[1].transpose = -12;
  f.motors[1].lowest_note = 60;
  Rig folded(f);
  folded.on(0, 60, 110);
  CHECK(folded.motors_on(0, 60) == std::vector<size_t>{0, 2});
  folded.on(1, 60, 110);  // motor 1 alone is free: it plays the note, no one doubles it
  CHECK(folded.motors_on(1, 60) == std::vector<size_t>{1});
  folded.off(0, 60);
  folded.on(2, 60, 127);  // the folded motor is busy; 0 and 2 are free
  CHECK(folded.motors_on(2, 60) == std::vector<size_t>{0, 2});
}

TEST_CASE("velocity: note-off, the pedal's lift, all-notes-off and all-sound-off end the doublers with the note") {
  Rig r(poly(4));
  r.on(0, 60, 127);
  REQUIRE(r.sounding() == 3);
  r.off(0, 60);
  CHECK(r.all_silent());

  r.cc(0, kCcSustain, 127);
  r.on(0, 60, 110);
  r.off(0, 60);  // the pedal holds the note and its doubler
  REQUIRE(r.motors_on(0, 60).size() == 2);
  for (size_t m : r.motors_on(0, 60)) CHECK(r.a.motor(m).sustained);
  r.cc(0, kCcSustain, 0);
  CHECK(r.all_silent());

  r.on(0, 60, 127);
  r.cc(0, kCcAllNotesOff, 0);
  CHECK(r.all_silent());
  r.on(0, 60, 127);
  r.cc(0, kCcSustain, 127);
  r.cc(0, kCcAllSoundOff, 0);
  CHECK(r.all_silent());
}

TEST_CASE("velocity: the same key struck again keeps its motor and gets the doublers its new velocity asks for") {
  Rig r(poly(4));
  r.on(0, 60, 127);
  REQUIRE(r.motors_on(0, 60) == std::vector<size_t>{0, 1, 2});
  r.on(0, 60, 110);  // softer: the highest doubler goes
  CHECK(unison(r, 0, 60, expected_period(60)) == std::vector<size_t>{0, 1});
  r.on(0, 60, 50);
  CHECK(r.motors_on(0, 60) == std::vector<size_t>{0});
  r.on(0, 60, 127);
  CHECK(unison(r, 0, 60, expected_period(60)) == std::vector<size_t>{0, 1, 2});
  CHECK_FALSE(r.a.motor(0).doubling);
  // Re-struck under the pedal after its release: every motor of the note is held again.
  r.cc(0, kCcSustain, 127);
  r.off(0, 60);
  r.on(0, 60, 127);
  r.cc(0, kCcSustain, 0);
  CHECK(r.motors_on(0, 60).size() == 3);
  r.off(0, 60);
  CHECK(r.all_silent());
}

TEST_CASE("velocity: a new note with no motor free takes a doubler before it steals a note") {
  const Priority priority = GENERATE(Priority::kOldest, Priority::kLowest, Priority::kHighest);
  INFO("priority " << int(priority));
  Rig r(poly(4, priority));
  r.on(0, 60, 127);  // motors 0, 1, 2
  r.on(0, 62);       // motor 3
  // 64 is above every sounding note (kLowest would refuse to steal) and 59 below (kHighest
  // would): a doubler costs no note, so each priority takes it.
  r.on(0, 64);
  CHECK(unison(r, 0, 60, expected_period(60)).size() == 2);
  CHECK(r.motors_on(0, 62).size() == 1);
  CHECK(unison(r, 0, 64, expected_period(64)).size() == 1);
  r.on(0, 59);
  CHECK(unison(r, 0, 60, expected_period(60)).size() == 1);
  CHECK_FALSE(r.a.motor(r.motors_on(0, 60).at(0)).doubling);
  CHECK(r.motors_on(0, 59).size() == 1);
  CHECK(r.sounding() == 4);
  // No doubler left: the next note steals as its priority says (oldest: 60).
  if (priority == Priority::kOldest) {
    r.on(0, 65);
    CHECK(r.motors_on(0, 60).empty());
    CHECK(r.motors_on(0, 65).size() == 1);
  }
}

TEST_CASE("velocity: the biggest unison gives a motor first, a doubler before the note's own motor") {
  Rig r(poly(5));
  r.on(0, 60, 110);  // motors 0, 1
  r.on(0, 62, 127);  // motors 2, 3, 4
  r.on(0, 64);
  CHECK(r.motors_on(0, 60) == std::vector<size_t>{0, 1});
  CHECK(r.motors_on(0, 62).size() == 2);
  CHECK_FALSE(r.a.motor(2).doubling);  // 62 keeps its own motor
  r.on(0, 65);  // two unisons of two: the older note's doubler
  CHECK(r.motors_on(0, 60) == std::vector<size_t>{0});
  CHECK(r.motors_on(0, 62).size() == 2);
}

TEST_CASE("velocity: a note's own motor taken for a note its doublers cannot play hands the note to a doubler") {
  AllocatorConfig c = poly(3);
  for (size_t m : {1, 2}) {  // D4 to F#4: no C in range, so C3 has nowhere to fold here
    c.motors[m].lowest_note = 62;
    c.motors[m].highest_note = 66;
  }
  Rig r(c);
  r.on(0, 64, 127);
  REQUIRE(r.motors_on(0, 64) == std::vector<size_t>{0, 1, 2});
  r.on(0, 48);  // only motor 0 plays it
  CHECK(r.motors_on(0, 48) == std::vector<size_t>{0});
  CHECK(r.board[0] == expected_period(48));
  CHECK(unison(r, 0, 64, expected_period(64)) == std::vector<size_t>{1, 2});
  CHECK_FALSE(r.a.motor(1).doubling);  // the note's own motor now
  CHECK(r.a.motor(2).doubling);
  r.off(0, 64);  // and its key still ends it everywhere
  CHECK(r.motors_on(0, 64).empty());
  CHECK(r.sounding() == 1);
}

TEST_CASE("velocity: bend, vibrato and glide move the doublers with the note") {
  AllocatorConfig c = poly(4);
  c.motors[1].tuning_cents = -5.0;
  Rig r(c);
  // Glide: the doubler slides with the note's own motor, from the note that motor played.
  r.at(control_change(0, kCcPortamento, 127), 1000);
  r.at(control_change(0, kCcPortamentoTime, 20), 1000);  // 320 ms
  r.at(note_on(0, 57, kSoft), 1000000);
  r.at(note_off(0, 57), 1200000);
  r.at(note_on(0, 69, 110), 1250000);
  REQUIRE(r.motors_on(0, 69) == std::vector<size_t>{0, 1});
  CHECK(r.board[0] == expected_period(57));
  CHECK(r.board[1] == expected_period(57, 0, -5.0));
  r.tick(1250000 + 160000);
  CHECK(r.board[0] == expected_period(63));
  CHECK(r.board[1] == expected_period(63, 0, -5.0));
  r.tick(1250000 + 320000);
  CHECK(r.board[0] == expected_period(69));
  CHECK(r.board[1] == expected_period(69, 0, -5.0));
  // Bend: both.
  r.at(pitch_bend(0, 8192 + 4096), 1600000);  // +1 semitone
  CHECK(r.board[0] == expected_period(69, 1.0));
  CHECK(r.board[1] == expected_period(69, 1.0, -5.0));
  r.at(pitch_bend(0, 8192), 1600000);
  // Vibrato: the same phase on both, from the note's start.
  r.at(control_change(0, kCcModWheel, 127), 1600000);
  for (uint64_t us : {1700000, 1745000, 1800000}) {
    r.tick(us);
    const double cents = vibrato_cents(c.vibrato, 127, us - 1250000);
    INFO("at " << us << " us: " << cents << " cents");
    CHECK(r.board[0] == expected_period(69, 0, cents));
    CHECK(r.board[1] == expected_period(69, 0, cents - 5.0));
  }
}

TEST_CASE("velocity: panic and reconfiguration forget the doublers") {
  Rig r(poly(4));
  r.on(0, 60, 127);
  r.on(0, 62);
  std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
  out.resize(r.a.panic(out.data(), out.size()));
  for (const auto &p : out) r.board[p.motor] = p.period_q8;
  CHECK(r.all_silent());
  r.on(0, 64, 110);
  CHECK(r.motors_on(0, 64).size() == 2);
  REQUIRE(r.a.configure(poly_velocity(4, 0, 0)));  // doubling off
  r.send(control_change(0, kCcAllSoundOff, 0));
  CHECK(r.all_silent());
  r.on(0, 64, 127);
  CHECK(r.motors_on(0, 64).size() == 1);
}

TEST_CASE("velocity: kMono and kChannel play as before, whatever the velocity") {
  Rig mono(mono_config());
  mono.on(0, 60, 127);
  CHECK(mono.motors_on(0, 60) == std::vector<size_t>{0, 1});  // channel 0's group, no more
  CHECK(mono.sounding() == 2);
  AllocatorConfig c = poly(4);
  c.policy = Policy::kChannel;
  Rig channel(c);
  channel.on(1, 60, 127);
  CHECK(channel.motors_on(1, 60) == std::vector<size_t>{1});
  CHECK(channel.sounding() == 1);
  for (size_t m = 0; m < 4; ++m) CHECK_FALSE(channel.a.motor(m).doubling);
}

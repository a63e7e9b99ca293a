// test_allocator_pitch.cpp: the allocator's pitch: bend and its range, controllers and channel mode
// messages, per-motor range, mutes, transpose and tuning, percussion, vibrato and glide.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "allocator_rig.h"

using namespace stepchoir;
using namespace stepchoir::allocator_test;

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
  MidiEvent on = note_on(0, 69, kSoft);
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
  r.at(control_change(0, kCcPortamento, 127), 1000);
  r.at(control_change(0, kCcPortamentoTime, 20), 1000);  // 20 x 16 ms = 320 ms
  r.at(note_on(0, 57, kSoft), 1000000);
  CHECK(r.board[0] == expected_period(57));  // nothing played before: no glide
  r.at(note_off(0, 57), 1200000);
  r.at(note_on(0, 69, kSoft), 1250000);  // 50 ms after: the same motor slides up an octave
  REQUIRE(r.motors_on(0, 69) == std::vector<size_t>{0});
  CHECK(r.board[0] == expected_period(57));
  CHECK(r.a.vibrating());  // the engine ticks while it glides
  r.tick(1250000 + 160000);
  CHECK(r.board[0] == expected_period(63));  // half way: half the octave, evenly in cents
  r.tick(1250000 + 240000);
  CHECK(r.board[0] == expected_period(66));
  r.tick(1250000 + 320000);
  CHECK(r.board[0] == expected_period(69));  // landed exactly
  CHECK_FALSE(r.a.vibrating());
  // A motor silent for longer than kGlideAfterSilenceUs starts its note on pitch.
  r.at(note_off(0, 69), 2000000);
  r.at(note_on(0, 60, kSoft), 2000000 + kGlideAfterSilenceUs + 1000);
  CHECK(r.board[0] == expected_period(60));
  // Glide off: no slide.
  r.at(control_change(0, kCcPortamento, 0), 2500000);
  r.at(note_on(0, 72, kSoft), 2500000);
  CHECK(r.board[r.motors_on(0, 72).at(0)] == expected_period(72));
}

TEST_CASE("glide: in mono the channel's note always slides, even after a silence") {
  Rig r(mono_on_motor_0(1));
  MidiEvent e = control_change(0, kCcPortamento, 127);
  r.send(e);
  r.send(control_change(0, kCcPortamentoTime, 10));  // 160 ms
  e = note_on(0, 60, kSoft);
  e.timestamp_us = 1000000;
  r.send(e);
  e = note_off(0, 60);
  e.timestamp_us = 1100000;
  r.send(e);
  e = note_on(0, 64, kSoft);
  e.timestamp_us = 3000000;  // two seconds of silence
  r.send(e);
  CHECK(r.board[0] == expected_period(60));
  std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
  out.resize(r.a.tick(3000000 + 80000, out.data(), out.size()));
  REQUIRE(out.size() == 1);
  CHECK(out[0].period_q8 == expected_period(62));
}

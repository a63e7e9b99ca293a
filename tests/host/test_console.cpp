// test_console.cpp: what the live console shows, without a terminal: the console's model
// (pitch and cents from periods, MIDI events, links, warnings, a carriage's bar), its layout at
// 80x24 and smaller (live's and jam's screens), the plain status line, and what each key does.
// Built into test_live; what it reads from a running session: test_console_live.cpp; play's
// model: test_console_play.cpp.
#include <catch2/catch.hpp>

#include <cmath>
#include <utility>
#include <vector>

#include "cli/console.h"
#include "cli/console_model.h"
#include "cli/console_view.h"
#include "core/pitch.h"

using namespace stepchoir;

TEST_CASE("console: a motor's note, Hz and cents from its period, the board clock and its tuning", "[console]") {
  MotorConfig music;  // 16 MHz, no tuning
  ConsoleMotor row;
  motor_pitch(69, hz_to_period_q8(440.0, 16e6), music, 440.0, &row);
  CHECK(row.note == 69);
  CHECK(row.hz == Approx(440.0).epsilon(1e-6));
  CHECK(std::fabs(row.cents) < 0.01);
  // Bent up 50 cents (or a vibrato's peak): the period says so.
  motor_pitch(69, hz_to_period_q8(440.0 * std::exp2(50.0 / 1200), 16e6), music, 440.0, &row);
  CHECK(row.cents == Approx(50.0).margin(0.01));
  // A motor tuned 10 cents up plays its note 10 cents up: that is no bend. A4 = 432 Hz too.
  music.tuning_cents = 10;
  motor_pitch(60, hz_to_period_q8(note_hz(60.1, 432.0), 16e6), music, 432.0, &row);
  CHECK(std::fabs(row.cents) < 0.01);
  // Another board clock: the same period is another pitch.
  music.tuning_cents = 0;
  music.f_cpu_hz = 8000000;
  motor_pitch(57, hz_to_period_q8(440.0, 16e6), music, 440.0, &row);
  CHECK(row.hz == Approx(220.0).epsilon(1e-6));
  CHECK(std::fabs(row.cents) < 0.01);
  motor_pitch(-1, 0, music, 440.0, &row);
  CHECK(row.note == -1);
  CHECK(row.hz == 0);
  CHECK(motor_note_name(-1) == "--");
  CHECK(motor_note_name(61) == "C#4");
}

TEST_CASE("console: MIDI events in a few words", "[console]") {
  CHECK(describe_event(0x90, 60, 100) == "on  ch1 C4 100");
  CHECK(describe_event(0x91, 60, 0) == "off ch2 C4");
  CHECK(describe_event(0x8F, 69, 10) == "off ch16 A4");
  CHECK(describe_event(0xB0, 64, 127) == "cc64 ch1 = 127");
  CHECK(describe_event(0xC0, 4, 0) == "prog ch1 5");
  CHECK(describe_event(0xE0, 0, 0x50) == "bend ch1 +2048");
  CHECK(describe_event(0xE0, 0, 0x40) == "bend ch1 0");
  CHECK(describe_event(0xD2, 90, 0) == "pres ch3 90");
  CHECK(describe_event(0xA0, 60, 90) == "poly ch1 C4 90");
}

TEST_CASE("console: a link's health, rate and counters", "[console]") {
  BoardStats st;
  const uint64_t now = 100000000;
  CHECK(link_row(st, "/dev/ttyACM0", false, now, 0, 0).health == "no answer");
  st.last_status_us = now - 1000000;
  st.frames_sent = 130;
  st.board_errors = 2;
  st.last_error = sc::kErrLate;
  st.reconnects = 1;
  st.reversals = 17;
  ConsoleLink l = link_row(st, "/dev/ttyACM0", false, now, 100, 0.5);
  CHECK(l.health == "ok");
  CHECK(l.healthy);
  CHECK(l.frames_per_s == Approx(60.0));
  CHECK(l.last_error == sc::error_name(sc::kErrLate));
  CHECK(l.reconnects == 1);
  CHECK(l.reversals == 17);
  st.watchdog_tripped = true;
  CHECK(link_row(st, "x", false, now, 0, 0).health == "watchdog");
  st.read_failed = true;
  CHECK(link_row(st, "x", false, now, 0, 0).health == "READ FAILED");
  st.write_failed = true;
  CHECK(link_row(st, "x", false, now, 0, 0).health == "WRITE FAILED");
  CHECK(link_row(st, "x", true, now, 0, 0).health == "reconnecting");
  CHECK_FALSE(link_row(st, "x", true, now, 0, 0).healthy);
}

TEST_CASE("console: warnings in plain words: states while they last, counters for ten seconds", "[console]") {
  ConsoleModel m;
  m.midi_input = "keys";
  ConsoleLink ok;
  ok.name = "/dev/ttyACM0";
  ok.health = "ok";
  ok.healthy = true;
  m.links = {ok, ok};
  m.links[1].name = "/dev/ttyACM1";
  m.motors.resize(2);
  WarningTracker t;
  t.update(&m, 0, 1000000);
  CHECK(m.warnings.empty());
  // A link lost, the MIDI input gone, a stuck switch: warned about while so.
  m.links[1].health = "reconnecting";
  m.midi_input.clear();
  m.motors[1].switch_fault = true;
  t.update(&m, 0, 2000000);
  REQUIRE(m.warnings.size() == 3);
  CHECK(m.warnings[0] == "/dev/ttyACM1: link lost; reopening the port (its motors are silent)");
  CHECK(m.warnings[1] == "MIDI input gone: every note released; waiting for it to come back");
  CHECK(m.warnings[2] == "motor 1: its end switch is stuck; it turns at the soft limits");
  m.links[1].health = "ok";
  m.midi_input = "keys";
  m.motors[1].switch_fault = false;
  // Board errors, bad frames and dropped events: news for ten seconds after each rise.
  m.links[0].board_errors = 3;
  m.links[0].last_error = "late";
  m.links[1].bad_frames = 2;
  t.update(&m, 5, 3000000);
  REQUIRE(m.warnings.size() == 3);
  CHECK(m.warnings[0] == "/dev/ttyACM0: the board reported 3 errors (latest: late)");
  CHECK(m.warnings[1] == "/dev/ttyACM1: 2 frames the board could not read (line noise?)");
  CHECK(m.warnings[2] == "5 MIDI events dropped: the engine fell behind");
  t.update(&m, 5, 12000000);
  CHECK(m.warnings.size() == 3);
  t.update(&m, 5, 13500000);
  CHECK(m.warnings.empty());
  m.links[0].board_errors = 4;
  t.update(&m, 5, 14000000);
  CHECK(m.warnings.size() == 1);
}

TEST_CASE("console: a carriage on its rail as a bar", "[console]") {
  ConsoleMotor m;
  m.travel_steps = 3200;
  m.has_position = true;
  m.position_steps = 1600;
  CHECK(rail_bar(m, 12) == "|-----o----|");
  m.position_steps = 0;
  CHECK(rail_bar(m, 12) == "|o----:----|");
  m.position_steps = 3200;
  CHECK(rail_bar(m, 12) == "|-----:---o|");
  m.position_steps = -40;  // past an end: the board turns it there
  CHECK(rail_bar(m, 12) == "<-----:----|");
  m.position_steps = 3300;
  CHECK(rail_bar(m, 12) == "|-----:---->");
  m.has_position = false;
  CHECK(rail_bar(m, 12) == "|          |");
  m.has_position = true;
  m.travel_steps = 0;  // no soft limits: no rail to draw
  m.position_steps = -123;
  CHECK(rail_bar(m, 12) == "pos -123    ");
}

namespace {

// A model as a rig of `motors` motors on two boards would give, A4 on motor 0.
ConsoleModel sample_model(size_t motors) {
  ConsoleModel m;
  m.motors.resize(motors);
  for (size_t i = 0; i < motors; ++i) {
    ConsoleMotor &mo = m.motors[i];
    mo.number = i;
    mo.travel_steps = 3200;
    mo.has_position = true;
    mo.position_steps = 1600;
  }
  m.motors[0].note = 69;
  m.motors[0].hz = 440.0;
  m.motors[1].muted = true;
  ConsoleLink l;
  l.name = "/dev/ttyACM0";
  l.health = "ok";
  l.healthy = true;
  m.links = {l, l};
  m.midi_input = "keys";
  m.recent = {{"on  ch1 A4 64", 200}};
  m.preset = 1;
  m.preset_count = 3;
  m.preset_name = "split";
  m.preset_program = 2;
  m.transpose = 12;
  m.warnings = {"one", "two", "three"};
  return m;
}

}  // namespace

TEST_CASE("console: the screen at 80x24, and what a small terminal keeps", "[console]") {
  ConsoleFooter f;
  f.keys = kKeysHelp;
  f.notices = {"old news", "preset 1 plain", "setlist 2/3 encore", "preset 2 split"};
  const ConsoleModel m = sample_model(9);
  auto lines = console_lines(m, f, 24, 80);
  REQUIRE(lines.size() == 24);
  for (const ScreenLine &l : lines) CHECK(l.text.size() <= 80);
  CHECK(lines[0].text.find("preset 2/3 split (program 2)  transpose +12") != std::string::npos);
  CHECK(lines[1].text == " #  note        Hz  cents   ends  rail");
  CHECK(lines[2].text.find(" 0  A4      440.00     +0      0  |") == 0);
  CHECK(lines[3].text.find("muted") != std::string::npos);
  CHECK(lines[23].text == kKeysHelp);
  std::string all;
  for (const ScreenLine &l : lines) all += l.text + "\n";
  for (const char *part : {"ttyACM0", "latency p50", "MIDI keys  last: on  ch1 A4 64 0.2s", "! three", "preset 2 split"})
    CHECK(all.find(part) != std::string::npos);
  CHECK(all.find("old news") == std::string::npos);  // the latest three messages only
  // 40x8: the title, as many motors as fit (the last says how many more), the keys.
  lines = console_lines(m, f, 8, 40);
  REQUIRE(lines.size() == 8);
  for (const ScreenLine &l : lines) CHECK(l.text.size() <= 40);
  CHECK(lines[1].text.find(" 0  A4") == 0);
  CHECK(lines[6].text == "    +4 more motors");
  CHECK(lines[7].text == std::string(kKeysHelp).substr(0, 40));
  // Room for the motors, then the warnings before the links.
  lines = console_lines(sample_model(2), f, 7, 80);
  CHECK(lines[3].text == "! one");
  CHECK(lines[5].text == "! three");
  // The learn prompt takes the last line, the actions list what may be typed.
  f.typing = true;
  f.typed = "mute_motor 2";
  lines = console_lines(m, f, 24, 80);
  CHECK(lines[23].text.find("learn> mute_motor 2_") == 0);
  all.clear();
  for (const ScreenLine &l : lines) all += l.text + "\n";
  CHECK(all.find("13 mute_motor") != std::string::npos);
  CHECK(console_lines(m, f, 1, 1).size() == 1);
}

TEST_CASE("console: a motor's row shows its own endstop hits - the link row its board's total", "[console]") {
  ConsoleModel m = sample_model(4);
  m.motors[1].reversals = 65535;  // muted too: the widest row
  m.motors[2].reversals = 12;
  m.motors[3].reversals = 3;
  m.motors[3].has_position = false;  // no status reply from its board yet: no count shown
  m.links.resize(1);
  m.links[0].reversals = 14;
  const auto lines = console_lines(m, ConsoleFooter{}, 24, 80);
  const std::string middle = "|-------------------o------------------|";  // 40: the widest bar
  CHECK(lines[2].text == " 0  A4      440.00     +0      0  " + middle);
  CHECK(lines[3].text == " 1  --                     65535  " + middle + " muted");
  CHECK(lines[3].text.size() == 80);
  CHECK(lines[4].text == " 2  --                        12  " + middle);
  CHECK(lines[5].text.rfind(" 3  --                            |  ", 0) == 0);
  CHECK(lines[6].text.find(" ends 14") != std::string::npos);
  // play: the same count and rail, a bar narrower by the board's name after it
  m.command = "play";
  m.motors[0].board = "/dev/ttyACM0";
  const std::string row = console_lines(m, ConsoleFooter{}, 24, 80)[2].text;
  CHECK(row.rfind(" 0  A4      440.00     +0      0  |", 0) == 0);
  CHECK(row.size() == 34 + 38 + 8);
  CHECK(row.substr(row.size() - 9) == "| ttyACM0");
}

TEST_CASE("console: jam's screen: the song's place, the rig's motor numbers, each board's clock", "[console]") {
  ConsoleModel m = sample_model(2);
  m.command = "jam";
  m.song = "playing 0:12 / 1:30";
  m.motors[0].number = 2;  // the song plays motors 0 and 1
  m.motors[1].number = 3;
  m.links.resize(1);
  m.links[0].has_clock = true;
  m.links[0].clock_ppm = -10.62;
  m.links[0].clock_residual_us = 958;
  ConsoleFooter f;
  const auto lines = console_lines(m, f, 24, 80);
  CHECK(lines[0].text.rfind("stepchoir jam  playing 0:12 / 1:30  preset 2/3 split (program 2)  transpose +12", 0) == 0);
  CHECK(lines[2].text.rfind(" 2  A4", 0) == 0);
  CHECK(lines[3].text.rfind(" 3  --", 0) == 0);
  CHECK(lines[5].text == "  song clock -10.6 ppm, fit within 958 us");
  CHECK(status_line(m).rfind("m2 A4  m3 --  |", 0) == 0);
}

TEST_CASE("console: the plain status line", "[console]") {
  ConsoleModel m = sample_model(2);
  m.links.resize(1);
  m.links[0].frames_sent = 12;
  m.links[0].bad_frames = 1;
  m.events = 5;
  m.latency_p50_us = 900;
  m.latency_p99_us = 2100;
  CHECK(status_line(m) == "m0 A4  m1 --  | /dev/ttyACM0 ok, 12 frames, 1 bad | 5 events, latency p50 900 us p99 2100 us");
}

TEST_CASE("console: keys", "[console]") {
  using K = KeyCommand::Kind;
  const std::vector<size_t> four{0, 1, 2, 3};
  for (int key : {27, int(' ')}) {
    CHECK(command_for_key(key, four).kind == K::kStage);
    CHECK(command_for_key(key, four).action.action == Action::kPanic);
  }
  const std::pair<int, Action> stage[] = {{'p', Action::kPresetNext},    {'P', Action::kPresetPrevious},
                                          {'s', Action::kSetlistNext},   {'S', Action::kSetlistPrevious},
                                          {'t', Action::kTransposeUp},   {'T', Action::kTransposeDown},
                                          {'o', Action::kOctaveUp},      {'O', Action::kOctaveDown}};
  for (const auto &[key, action] : stage) CHECK(command_for_key(key, four).action.action == action);
  const KeyCommand mute = command_for_key('3', four);
  CHECK(mute.kind == K::kStage);
  CHECK(mute.action.action == Action::kMuteMotor);
  CHECK(mute.action.motor == 3);
  CHECK(command_for_key('4', four).kind == K::kNone);  // no motor 4
  // jam with the song on motors 0 and 1: the keyboard's pool motor 0 is the rig's motor 2.
  CHECK(command_for_key('2', {2, 3}).action.motor == 0);
  CHECK(command_for_key('0', {2, 3}).kind == K::kNone);
  CHECK(command_for_key('l', four).kind == K::kLearn);
  CHECK(command_for_key('q', four).kind == K::kQuit);
  CHECK(command_for_key('x', four).kind == K::kNone);
}

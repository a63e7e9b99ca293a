// test_console.cpp: what the live console reads and shows, without a terminal: the board's
// status replies published in BoardStats, the engine's record of the latest MIDI events, the
// console's model (pitch and cents from periods, links, warnings), its layout at 80x24 and
// smaller, the plain status line, what each key does, and play's model from its plan's events.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <mutex>
#include <utility>
#include <vector>

#include "board/board.h"
#include "cli/console.h"
#include "cli/console_model.h"
#include "cli/console_view.h"
#include "core/pitch.h"
#include "live/event_log.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

// A FakeLink whose board answers: every read hands out one status reply (motor m at position
// positions[m] with reversals[m] reversals, motor 1's switch faulty, the board's total their sum).
class StatusLink : public FakeLink {
 public:
  StatusLink(std::vector<int32_t> positions, std::vector<uint16_t> reversals) {
    std::vector<uint8_t> payload(1 + sizeof(sc::StatusHead));
    payload[0] = sc::kMsgStatus;
    sc::StatusHead head{};
    for (uint16_t r : reversals) head.reversals = static_cast<uint16_t>(head.reversals + r);
    head.motor_count = static_cast<uint8_t>(positions.size());
    std::memcpy(&payload[1], &head, sizeof head);
    for (size_t m = 0; m < positions.size(); ++m) {
      sc::StatusMotor s{positions[m], static_cast<uint8_t>(m == 1 ? sc::kMotorEndstopFault : 0), reversals.at(m)};
      const auto *p = reinterpret_cast<const uint8_t *>(&s);
      payload.insert(payload.end(), p, p + sizeof s);
    }
    reply_ = frame(payload);
  }
  long read(uint8_t *out, size_t len, int) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const size_t n = std::min(len, reply_.size());
    std::memcpy(out, reply_.data(), n);
    return static_cast<long>(n);
  }

 private:
  std::vector<uint8_t> reply_;
};

}  // namespace

TEST_CASE("live: status replies publish each carriage's position, switch faults and the reversals", "[live][console]") {
  StatusLink link({1600, -12, 3200, 0}, {5, 0, 2, 65535});
  const std::vector<LiveBoard> pool{LiveBoard{&link, 4, 16000000}};
  const AllocatorConfig config = pool_config(pool, Policy::kPoly);
  LiveSession session(pool, config);
  session.start();
  const BoardStats &st = session.board_stats(0);
  REQUIRE(eventually([&] { return st.last_status_us.load() != 0; }));
  ConsoleSources src;
  src.reconnecting = {false};
  src.music = config;
  const ConsoleModel m = ConsoleSampler().sample(session, src, monotonic_us());
  session.stop();
  CHECK(st.position_steps[0].load() == 1600);
  CHECK(st.position_steps[1].load() == -12);
  CHECK(st.position_steps[2].load() == 3200);
  CHECK(st.endstop_fault_mask.load() == 0x02);
  CHECK(std::vector<uint16_t>{st.motor_reversals[0], st.motor_reversals[1], st.motor_reversals[2],
                              st.motor_reversals[3]} == std::vector<uint16_t>{5, 0, 2, 65535});
  CHECK(st.reversals.load() == 6);  // the board's total, wrapped
  CHECK(st.reconnects.load() == 0);
  CHECK(session.motor_board(3) == 0);
  CHECK(session.board_motor(3) == 3);
  // The console's rows: each motor its own count, the link the board's total.
  REQUIRE(m.motors.size() == 4);
  for (size_t i = 0; i < 4; ++i) {
    INFO("motor " << i);
    CHECK(m.motors[i].has_position);
    CHECK(m.motors[i].reversals == st.motor_reversals[i].load());
  }
  REQUIRE(m.links.size() == 1);
  CHECK(m.links[0].reversals == 6);
}

TEST_CASE("live: the event log returns the newest events first, with their age", "[live][console]") {
  EventLog log;
  EventLog::Entry out[EventLog::kEvents];
  CHECK(log.latest(out, EventLog::kEvents, 5000000) == 0);
  log.record(note_on(0, 60, 100, 1000000));
  log.record(control_change(2, 1, 64, 1500000));
  REQUIRE(log.latest(out, EventLog::kEvents, 2000000) == 2);
  CHECK(out[0].status == 0xB2);
  CHECK(out[0].data1 == 1);
  CHECK(out[0].data2 == 64);
  CHECK(out[0].age_ms == 500);
  CHECK(out[1].status == 0x90);
  CHECK(out[1].data1 == 60);
  CHECK(out[1].age_ms == 1000);
  // More than the ring holds: the newest kEvents, newest first; max bounds the count.
  for (uint8_t k = 0; k < 40; ++k) log.record(note_on(0, k, 1, 3000000));
  REQUIRE(log.latest(out, EventLog::kEvents, 3000000) == EventLog::kEvents);
  CHECK(out[0].data1 == 39);
  CHECK(out[EventLog::kEvents - 1].data1 == 40 - EventLog::kEvents);
  CHECK(log.latest(out, 3, 3000000) == 3);
  CHECK(log.count() == 42);
}

TEST_CASE("live: the engine records the events it applies", "[live][console]") {
  FakeLink link;
  LiveSession session({LiveBoard{&link, 4, 16000000}}, pool_config({LiveBoard{&link, 4, 16000000}}, Policy::kPoly));
  session.start();
  REQUIRE(session.midi_queue().try_enqueue(note_on(0, 69, 64, monotonic_us())));
  REQUIRE(eventually([&] { return session.recent_events().count() == 1; }));
  session.stop();
  EventLog::Entry e;
  REQUIRE(session.recent_events().latest(&e, 1, monotonic_us()) == 1);
  CHECK(e.status == 0x90);
  CHECK(e.data1 == 69);
  CHECK(e.age_ms < 10000);
}

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

TEST_CASE("console: the sampler reads a running session", "[live][console]") {
  FakeLink link;
  const std::vector<LiveBoard> pool{LiveBoard{&link, 4, 16000000}};
  const AllocatorConfig config = pool_config(pool, Policy::kPoly);
  LiveSession session(pool, config);
  session.start();
  REQUIRE(session.midi_queue().try_enqueue(note_on(0, 69, 64, monotonic_us())));
  REQUIRE(eventually([&] { return session.motor_note(0) == 69; }));
  REQUIRE(session.perform(StageAction{Action::kMuteMotor, 127, 2}));
  REQUIRE(eventually([&] { return session.stage_mutes() == 0x4; }));
  ConsoleSources src;
  src.board_names = {"fake-port"};
  src.reconnecting = {false};
  src.travel_steps.assign(4, 3200);
  src.music = config;
  src.midi_input = "keys";
  src.setlist_item = 1;
  src.setlist_count = 3;
  src.setlist_name = "encore";
  src.song_motors = 0x8;  // the setlist's song plays motor 3
  ConsoleSampler sampler;
  const ConsoleModel m = sampler.sample(session, src, monotonic_us());
  session.stop();
  REQUIRE(m.motors.size() == 4);
  CHECK(m.motors[0].note == 69);
  CHECK(m.motors[0].hz == Approx(440.0).epsilon(1e-4));
  CHECK(std::fabs(m.motors[0].cents) < 0.1);
  CHECK(m.motors[1].note == -1);
  CHECK(m.motors[2].muted);
  CHECK(m.motors[3].travel_steps == 3200);
  CHECK_FALSE(m.motors[0].has_position);  // the fake board never answers
  REQUIRE(m.links.size() == 1);
  CHECK(m.links[0].name == "fake-port");
  CHECK(m.links[0].health == "no answer");
  REQUIRE_FALSE(m.recent.empty());
  CHECK(m.recent[0].text == "on  ch1 A4 64");
  CHECK(m.events == 1);
  CHECK(m.preset == -1);
  CHECK(m.setlist_item == 1);
  CHECK(m.setlist_count == 3);
  CHECK(m.setlist_name == "encore");
  CHECK(m.motors[3].song);
  CHECK_FALSE(m.motors[2].song);
  const auto lines = console_lines(m, ConsoleFooter{}, 24, 80);
  CHECK(lines[0].text == "stepchoir live  preset -  transpose +0  setlist 2/3 encore");
  CHECK(lines[5].text.find("| song") != std::string::npos);
  CHECK(m.warnings == std::vector<std::string>{"fake-port: the board does not answer"});
}

TEST_CASE("console: play's rows from the plan's events at the player's position", "[console][play]") {
  // Board A: motors 0 and 1; board B: motor 0. Events by board, in time order, board motor numbers.
  auto on = [](double t, uint8_t m, double pitch) { return PlanEvent{t, m, false, pitch}; };
  auto off = [](double t, uint8_t m) { return PlanEvent{t, m, true, 0}; };
  const std::vector<std::vector<PlanEvent>> events{
      {on(0.0, 0, 69), on(0.5, 1, 60), off(1.0, 0), on(1.5, 0, 72.2), off(2.0, 1)},
      {on(1.0, 0, 57)}};
  std::vector<PlayBoard> boards{{"/dev/ttyACM0", 2, {}, false, {}, {}}, {"/dev/ttyACM1", 1, {}, false, {}, {}}};
  boards[1].stats.frames_sent = 42;
  boards[1].stats.clock_samples = 3;
  boards[1].stats.ppm = 2493.7;

  ConsoleModel m = play_model(events, boards, 0.7, 440.0);
  REQUIRE(m.motors.size() == 3);
  CHECK(m.motors[0].note == 69);
  CHECK(m.motors[0].hz == Approx(440.0));
  CHECK(m.motors[1].note == 60);
  CHECK(m.motors[1].hz == Approx(note_hz(60)));
  CHECK(m.motors[2].note == -1);  // board B's first note comes at 1.0 s
  CHECK(m.motors[2].number == 2);
  CHECK(m.motors[2].board == "/dev/ttyACM1");
  REQUIRE(m.links.size() == 2);
  CHECK(m.links[1].frames_sent == 42);
  CHECK(m.links[1].has_clock);
  CHECK_FALSE(m.links[0].has_clock);
  CHECK(m.warnings.empty());

  m = play_model(events, boards, 1.2, 440.0);  // motor 0 silent, board B sounding
  CHECK(m.motors[0].note == -1);
  CHECK(m.motors[1].note == 60);
  CHECK(m.motors[2].note == 57);
  m = play_model(events, boards, 2.5, 432.0);  // a pitch between notes, another A4
  CHECK(m.motors[0].note == 72);
  CHECK(m.motors[0].cents == Approx(20.0));
  CHECK(m.motors[0].hz == Approx(note_hz(72.2, 432.0)));
  CHECK(m.motors[1].note == -1);

  // A lost board and late entries, in plain words; the screen: no MIDI, latency or preset.
  boards[1].lost = true;
  boards[0].stats.late_reported = 3;
  m = play_model(events, boards, 2.5, 440.0);
  m.song = "playing 0:02 / 0:03";
  REQUIRE(m.warnings.size() == 2);
  CHECK(m.warnings[0] == "/dev/ttyACM0: notes came late 3 times (host fell behind: longer --lead-ms)");
  CHECK(m.warnings[1].find("/dev/ttyACM1 is lost") == 0);
  CHECK(m.links[1].health == "lost");
  ConsoleFooter footer;
  footer.keys = "keys";
  const std::vector<ScreenLine> lines = console_lines(m, footer, 24, 80);
  CHECK(lines[0].text == "stepchoir play  playing 0:02 / 0:03");
  CHECK(lines[2].text.rfind(" 0  C5      529.33    +20  ", 0) == 0);  // no status yet: no count, no carriage
  CHECK(lines[2].text.find_first_not_of(' ', 27) == lines[2].text.size() - 7);
  CHECK(lines[2].text.find("ttyACM0") != std::string::npos);
  for (const ScreenLine &l : lines) {
    CHECK(l.text.find("MIDI") == std::string::npos);
    CHECK(l.text.find("latency") == std::string::npos);
  }
  CHECK(lines.back().text == "keys");
}

TEST_CASE("console: play says in plain words which board is being reopened, and labels a pty's rows",
          "[console][play]") {
  const std::vector<std::vector<PlanEvent>> events{{PlanEvent{0.0, 0, false, 69}}, {PlanEvent{0.0, 0, false, 57}}};
  std::vector<PlayBoard> boards{{"/dev/pts/3", 1, {}, false, {}, {}}, {"/tmp/uno.pty", 1, {}, false, {}, {}}};
  boards[1].stats.reconnecting = true;
  boards[1].stats.reconnects = 1;
  const ConsoleModel m = play_model(events, boards, 0.5, 440.0);
  REQUIRE(m.links.size() == 2);
  CHECK(m.links[0].health == "ok");
  CHECK(m.links[1].health == "reconnecting");
  CHECK_FALSE(m.links[1].healthy);
  REQUIRE(m.warnings.size() == 1);
  CHECK(m.warnings[0] == "/tmp/uno.pty: link lost; reopening the port, the song goes on without it");
  const std::vector<ScreenLine> lines = console_lines(m, ConsoleFooter{}, 24, 80);
  REQUIRE(lines.size() >= 6);
  // A pty's rows name it by its path under /dev ("pts/3"), not its last part alone ("3").
  CHECK(lines[2].text.rfind(" 0  A4      440.00     +0  ", 0) == 0);
  CHECK(lines[2].text.substr(lines[2].text.size() - 6) == " pts/3");
  CHECK(lines[3].text.substr(lines[3].text.size() - 8) == " uno.pty");
  CHECK(lines[4].text.rfind("pts/3 ", 0) == 0);
  CHECK(lines[5].text.rfind("uno.pty ", 0) == 0);
  CHECK(lines[5].text.find("reconnecting") != std::string::npos);
}

TEST_CASE("console: play's rows show each carriage and its endstop hits from the board's status", "[console][play]") {
  // The song plays board motors 1 and 3 (plan motors 0 and 1) on a 400-step rail and an
  // unlimited one; the board's status reply, as the player keeps it.
  const std::vector<std::vector<PlanEvent>> events{{PlanEvent{0.0, 0, false, 69}, PlanEvent{0.0, 1, false, 57}}};
  std::vector<PlayBoard> boards{{"/dev/ttyACM0", 2, {}, false, {1, 3}, {400, 0}}};
  ConsoleModel m = play_model(events, boards, 0.5, 440.0);
  CHECK_FALSE(m.motors[0].has_position);  // no status reply yet: blank
  std::vector<ScreenLine> lines = console_lines(m, ConsoleFooter{}, 24, 80);
  CHECK(lines[2].text.substr(0, 34) == " 0  A4      440.00     +0         ");

  PlayerStats &s = boards[0].stats;
  s.has_status = true;
  s.motor_position[1] = 100;
  s.motor_reversals[1] = 7;
  s.motor_position[3] = -250;
  s.motor_reversals[3] = 0;
  s.motor_flags[3] = sc::kMotorEndstopFault;
  s.motor_position[0] = 999;  // a motor the song does not play
  s.motor_reversals[0] = 5;
  s.board_reversals = 12;
  m = play_model(events, boards, 0.5, 440.0);
  REQUIRE(m.motors.size() == 2);
  CHECK(m.motors[0].has_position);
  CHECK(m.motors[0].position_steps == 100);
  CHECK(m.motors[0].travel_steps == 400);
  CHECK(m.motors[0].reversals == 7);
  CHECK_FALSE(m.motors[0].switch_fault);
  CHECK(m.motors[1].position_steps == -250);
  CHECK(m.motors[1].reversals == 0);
  CHECK(m.motors[1].switch_fault);
  CHECK(m.links[0].reversals == 12);
  lines = console_lines(m, ConsoleFooter{}, 24, 80);
  // Row 0: its hits, then its carriage a quarter along the rail, then the board.
  CHECK(lines[2].text.substr(0, 34) == " 0  A4      440.00     +0      7  ");
  const std::string bar = lines[2].text.substr(34, lines[2].text.find(" ttyACM0") - 34);
  REQUIRE(bar.size() >= 7);
  CHECK(bar.front() == '|');
  CHECK(bar.back() == '|');
  const size_t at = bar.find('o');  // the carriage ('|' ends, ':' the middle)
  REQUIRE(at != std::string::npos);
  CHECK(std::fabs(double(at - 1) / double(bar.size() - 3) - 0.25) < 0.05);
  CHECK(lines[2].text.size() <= 80);
  CHECK(lines[2].text.substr(lines[2].text.size() - 8) == " ttyACM0");
  // Row 1: no rail (unlimited travel): its position in steps; its stuck switch said.
  CHECK(lines[3].text.find("pos -250") != std::string::npos);
  CHECK(lines[3].text.find("switch stuck") != std::string::npos);
  CHECK(lines[4].text.find("ends 12") != std::string::npos);
}

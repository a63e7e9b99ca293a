// test_driver.cpp: the real firmware on the virtual board powers its drivers down when idle and
// wakes them in time (kMsgDriver, kMsgDriverAct): SLEEP, the Uno's shared ENABLE, RESET, and the
// refusals. Every figure is measured from the trace in CPU cycles (no pacing, no wall clock).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "e2e_more.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

const uint64_t kMsCycles = 16000;  // cycles a millisecond at 16 MHz
const uint64_t kPollCycles = kMsCycles;  // the firmware checks idle motors once a millisecond

// A virtual board (no pacing, traced) with the given extra options and a host session on it
// that said hello and turned the watchdog off (the host may be slower than the board).
struct DriverRig {
  std::string trace_path;
  VboardProcess vb;
  Board b;
  Caps caps;

  DriverRig(const std::string &name, const std::vector<std::string> &extra)
      : trace_path(e2e::scratch(name + ".csv")), vb(args(trace_path, extra)), b(open_link(vb.pty())), caps(b.hello()) {
    b.send(e2e::watchdog_payload(0));
  }
  static std::vector<std::string> args(const std::string &trace, const std::vector<std::string> &extra) {
    std::vector<std::string> a{"--board", "uno", "--no-pacing", "--seconds", "120", "--trace", trace, "--quiet"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
  // Configures motor d.motor (a long rail: no reversal) and its driver; requires no refusal.
  void configure(const sc::DriverBody &d) {
    b.send(config_payload(e2e::motor_config(d.motor, 1000000)));
    b.send(driver_payload(d));
    const auto err = b.wait_reply(sc::kMsgError, 200);
    INFO("error " << (err ? sc::error_name((*err)[1]) : "none"));
    REQUIRE_FALSE(err);
  }
  void play(uint8_t motor, uint32_t period_q8) { b.send(e2e::tone_payload(motor, period_q8)); }
  void act(uint8_t motor, uint8_t action) { b.send(driver_act_payload(motor, action)); }
  // Waits `seconds` of board time.
  void wait(double seconds) { e2e::wait_board_time(b, e2e::board_ticks(b) + e2e::ticks_for(seconds, caps.f_cpu_hz)); }
  // Stops the board, requires a clean exit, reads the trace.
  tr::Trace finish() {
    const int rc = vb.stop();
    REQUIRE(rc == 0);
    return tr::read_trace(trace_path);
  }
};

const uint32_t kPeriod1k = 16000u << 8;  // 1000 Hz, ticks q8

// The steps of one motor cut into notes at gaps longer than 1.5 ms (one and a half of the
// longest period these tests play, and less than the silences between their notes): [first,
// last] indices.
std::vector<std::pair<size_t, size_t>> notes_of(const std::vector<tr::Step> &s) {
  std::vector<std::pair<size_t, size_t>> out;
  for (size_t i = 0; i < s.size(); ++i)
    if (i == 0 || s[i].rise_cycle - s[i - 1].rise_cycle > 3 * kMsCycles / 2) out.push_back({i, i});
    else out.back().second = i;
  return out;
}

// The first change of a level to `value` after `cycle` (nullptr if none).
const tr::LevelChange *first_after(const std::vector<tr::LevelChange> &changes, uint64_t cycle, uint8_t value) {
  for (const auto &c : changes)
    if (c.cycle > cycle && c.value == value) return &c;
  return nullptr;
}

// The first step at or after `cycle` (its index; steps.size() if none).
size_t first_step_from(const std::vector<tr::Step> &s, uint64_t cycle) {
  size_t k = 0;
  while (k < s.size() && s[k].rise_cycle < cycle) ++k;
  return k;
}

// Changes to `value` within [from, to].
size_t count_between(const std::vector<tr::LevelChange> &changes, uint64_t from, uint64_t to, uint8_t value) {
  size_t n = 0;
  for (const auto &c : changes) n += c.cycle >= from && c.cycle <= to && c.value == value;
  return n;
}

// The virtual board's count of steps a motor's driver did not take (asleep, waking, disabled,
// in reset), from the trace summary.
uint64_t lost_steps(const tr::Trace &t, int motor) {
  const std::string head = "summary motor=" + std::to_string(motor) + " ";
  for (const auto &line : t.summary_lines)
    if (line.rfind(head, 0) == 0) return std::stoull(line.substr(line.find(" lost_steps=") + 12));
  throw std::runtime_error("no summary for motor " + std::to_string(motor));
}

}  // namespace

TEST_CASE("driver: uno idle sleep - SLEEP low idle_ms after the last step - a live note wakes it, steps wake_us later",
          "[driver]") {
  DriverRig r("driver-idle-sleep", {"--sleep-pin", "1=14", "--wake-us", "1000"});
  r.configure({1, 14, sc::kPinNone, sc::kIdleSleep, 50, 1000});
  r.play(1, kPeriod1k);
  r.wait(0.1);
  r.play(1, 0);
  r.wait(0.2);  // idle for 50 ms of it: asleep
  r.play(1, kPeriod1k);
  r.wait(0.05);
  r.play(1, 0);
  const tr::Trace t = r.finish();
  const tr::MotorTrace &m = t.motor[1];
  const auto notes = notes_of(m.steps);
  REQUIRE(notes.size() == 2);
  const uint64_t first_start = m.steps[notes[0].first].rise_cycle, first_end = m.steps[notes[0].second].rise_cycle;
  CHECK(count_between(m.sleeps, first_start, first_end, 0) == 0);  // never asleep while it plays
  const tr::LevelChange *low = first_after(m.sleeps, first_end, 0);
  REQUIRE(low);
  const uint64_t wake_at = m.steps[notes[1].first].rise_cycle;
  const tr::LevelChange *high = first_after(m.sleeps, low->cycle, 1);
  REQUIRE(high);
  std::printf("driver idle sleep: SLEEP low %.3f ms after the last step (idle 50 ms), first step %.3f ms after SLEEP "
              "rose (wake 1 ms)\n",
              double(low->cycle - first_end) / kMsCycles, double(wake_at - high->cycle) / kMsCycles);
  // the silence comes at most a period after the last step; seen within a check, idle a check later
  CHECK(low->cycle - first_end >= 50 * kMsCycles);
  CHECK(low->cycle - first_end <= 50 * kMsCycles + kMsCycles + 2 * kPollCycles + kMsCycles / 2);
  CHECK(high->cycle < wake_at);
  CHECK(wake_at - high->cycle >= 1000 * 16u);
  CHECK(wake_at - high->cycle <= 1500 * 16u);
  CHECK(lost_steps(t, 1) == 0);
  CHECK(m.steps.size() >= notes[0].second + 1 + 45);  // the second note played its 50 ms
}

TEST_CASE("driver: uno a timed note on a sleeping motor starts exactly on its time, SLEEP high wake_us before",
          "[driver]") {
  DriverRig r("driver-timed", {"--sleep-pin", "1=14", "--wake-us", "1700"});
  r.configure({1, 14, sc::kPinNone, sc::kIdleSleep, 20, 1700});
  r.play(1, kPeriod1k);  // a note, then silence: asleep 20 ms later
  r.wait(0.03);
  r.play(1, 0);
  r.wait(0.1);
  // motor 0 (no driver settings, awake) gives the trace's offset from board time
  const uint32_t at0 = e2e::start_note_at(r.b, 0, kPeriod1k, r.caps.f_cpu_hz);
  const uint32_t at1 = e2e::start_note_at(r.b, 1, kPeriod1k, r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at1 + e2e::ticks_for(0.05, r.caps.f_cpu_hz));
  r.play(0, 0);
  r.play(1, 0);
  const tr::Trace t = r.finish();
  const tr::MotorTrace &m = t.motor[1];
  const auto notes = notes_of(m.steps);
  REQUIRE(notes.size() == 2);
  tr::MotorTrace timed;  // the timed note alone
  timed.steps.assign(m.steps.begin() + std::ptrdiff_t(notes[1].first), m.steps.end());
  const int64_t offset0 = e2e::grid_cycle_offset(t.motor[0], at0, kPeriod1k);
  const int64_t offset1 = e2e::grid_cycle_offset(timed, at1, kPeriod1k);
  const tr::LevelChange *low = first_after(m.sleeps, m.steps[notes[0].second].rise_cycle, 0);
  REQUIRE(low);
  const tr::LevelChange *high = first_after(m.sleeps, low->cycle, 1);
  REQUIRE(high);
  const uint64_t first = timed.steps.front().rise_cycle;
  std::printf("driver timed: the sleeping motor's note %+lld cycles from the awake one's offset; SLEEP rose %.3f ms "
              "before it (wake 1.7 ms)\n",
              (long long)(offset1 - offset0), double(first - high->cycle) / kMsCycles);
  CHECK(std::llabs(offset1 - offset0) <= 16);  // on its tick, as an awake motor's note (1 us)
  CHECK(high->cycle < first);
  CHECK(first - high->cycle >= 1700 * 16u);
  CHECK(lost_steps(t, 1) == 0);
}

TEST_CASE("driver: uno silence drops a motor's timed note far ahead - its driver is not held awake for it, another "
          "motor's timed note plays",
          "[driver]") {
  DriverRig r("driver-silence", {"--sleep-pin", "1=14", "--wake-us", "1000"});
  r.configure({1, 14, sc::kPinNone, sc::kIdleSleep, 50, 1000});
  const uint32_t now = e2e::board_ticks(r.b);
  const uint32_t at0 = now + e2e::ticks_for(0.1, r.caps.f_cpu_hz), at1 = now + e2e::ticks_for(20.0, r.caps.f_cpu_hz);
  r.b.send(at_payload(at0, {{0, kPeriod1k}}));  // in time order
  r.b.send(at_payload(at1, {{1, kPeriod1k}}));  // would wake motor 1's driver and hold it awake until then
  r.b.send({sc::kMsgSilence, 0x02});            // motor 1's entry dropped, motor 0's kept
  REQUIRE_FALSE(r.b.wait_reply(sc::kMsgError, 100));
  r.wait(0.3);
  r.play(0, 0);
  const tr::Trace t = r.finish();
  const tr::MotorTrace &m = t.motor[1];
  CHECK(m.steps.empty());
  // Asleep at the end, idle_ms after the silence: held for the dropped note, it would stay awake
  // (SLEEP high) for 20 s.
  REQUIRE_FALSE(m.sleeps.empty());
  CHECK(m.sleeps.back().value == 0);
  const auto notes = notes_of(t.motor[0].steps);
  REQUIRE(notes.size() == 1);
  std::printf("driver silence: motor 1's SLEEP changed %zu times, asleep at the end; motor 0's timed note played %zu "
              "steps\n",
              m.sleeps.size(), notes[0].second - notes[0].first + 1);
  CHECK(notes[0].second - notes[0].first + 1 >= 150);  // about 0.2 s of 1 kHz
}

TEST_CASE("driver: uno idle disable - the shared ENABLE goes off once every motor is idle, a motor with idle none "
          "keeps it on",
          "[driver]") {
  DriverRig r("driver-idle-disable", {});
  for (uint8_t m = 0; m < 4; ++m) r.configure({m, sc::kPinNone, sc::kPinNone, sc::kIdleDisable, 40, 500});
  r.play(0, kPeriod1k);
  r.play(1, 12000u << 8);
  r.wait(0.1);
  r.play(0, 0);
  r.wait(0.1);  // motor 0 idle for more than 40 ms, motor 1 still playing: ENABLE stays on
  r.play(1, 0);
  r.wait(0.15);
  r.play(2, kPeriod1k);  // ENABLE on again for the next note
  r.wait(0.05);
  r.play(2, 0);
  r.wait(0.15);
  r.configure({3, sc::kPinNone, sc::kPinNone, sc::kIdleNone, 40, 500});
  r.play(0, kPeriod1k);
  r.wait(0.05);
  r.play(0, 0);
  r.wait(0.2);  // motor 3's idle none keeps ENABLE on
  const tr::Trace t = r.finish();
  const auto &en = t.motor[0].enables;  // the shared D8: the same rows for every motor (1 = off)
  const auto n0 = notes_of(t.motor[0].steps), n1 = notes_of(t.motor[1].steps), n2 = notes_of(t.motor[2].steps);
  REQUIRE(n0.size() == 2);
  REQUIRE(n1.size() == 1);
  REQUIRE(n2.size() == 1);
  const uint64_t m0_end = t.motor[0].steps[n0[0].second].rise_cycle;
  const uint64_t m1_end = t.motor[1].steps[n1[0].second].rise_cycle;
  CHECK(m1_end > m0_end + 80 * kMsCycles);
  CHECK(count_between(en, m0_end, m1_end, 1) == 0);  // not off while motor 1 plays
  const tr::LevelChange *off = first_after(en, m1_end, 1);
  REQUIRE(off);
  CHECK(off->cycle - m1_end >= 40 * kMsCycles);
  CHECK(off->cycle - m1_end <= 40 * kMsCycles + kMsCycles + 2 * kPollCycles + kMsCycles / 2);
  const tr::LevelChange *on = first_after(en, off->cycle, 0);
  REQUIRE(on);
  const uint64_t m2_start = t.motor[2].steps[n2[0].first].rise_cycle;
  std::printf("driver idle disable: ENABLE off %.3f ms after the last motor's last step (idle 40 ms); the next note "
              "%.3f ms after ENABLE on (wake 0.5 ms)\n",
              double(off->cycle - m1_end) / kMsCycles, double(m2_start - on->cycle) / kMsCycles);
  CHECK(m2_start - on->cycle >= 500 * 16u);
  CHECK(m2_start - on->cycle <= 1000 * 16u);
  const uint64_t m2_end = t.motor[2].steps[n2[0].second].rise_cycle;
  const tr::LevelChange *off2 = first_after(en, m2_end, 1);
  REQUIRE(off2);
  CHECK(off2->cycle - m2_end >= 40 * kMsCycles);
  // motor 3 with idle none: on for motor 0's last note, and on to the end
  const uint64_t last_start = t.motor[0].steps[n0[1].first].rise_cycle;
  REQUIRE(first_after(en, off2->cycle, 0));
  CHECK(first_after(en, off2->cycle, 0)->cycle < last_start);
  CHECK(count_between(en, last_start, t.end_cycle, 1) == 0);
  CHECK(t.end_cycle - t.motor[0].steps.back().rise_cycle > 150 * kMsCycles);
  for (int m = 0; m < 4; ++m) CHECK(lost_steps(t, m) == 0);
}

TEST_CASE("driver: uno acts - sleep stops the note and lowers SLEEP, wake raises it, reset pulses RESET - each note "
          "after steps wake_us later",
          "[driver]") {
  DriverRig r("driver-act", {"--sleep-pin", "2=15", "--reset-pin", "2=16"});
  r.configure({2, 15, 16, sc::kIdleNone, 1000, 1000});
  r.play(2, kPeriod1k);
  r.wait(0.03);
  r.act(2, sc::kActSleep);
  r.wait(0.03);
  r.act(2, sc::kActWake);
  r.play(2, kPeriod1k);
  r.wait(0.03);
  r.act(2, sc::kActReset);
  r.play(2, kPeriod1k);
  r.wait(0.03);
  r.play(2, 0);
  // refused: sleep without a SLEEP pin, an unknown action, a motor the Uno lacks, a short frame
  r.act(0, sc::kActSleep);
  r.act(0, sc::kActReset);
  r.act(2, 4);
  r.act(4, sc::kActWake);
  r.b.send({sc::kMsgDriverAct, 2});
  const auto errors = e2e::read_replies(r.b, sc::kMsgError, 5);
  const tr::Trace t = r.finish();
  std::vector<uint8_t> codes;
  for (const auto &e : errors) codes.push_back(e[1]);
  CHECK(codes == std::vector<uint8_t>{sc::kErrConfig, sc::kErrConfig, sc::kErrConfig, sc::kErrMotor, sc::kErrLength});
  // three notes: up to the sleep, from the wake to the reset, after the reset
  const tr::MotorTrace &m = t.motor[2];
  REQUIRE(m.sleeps.size() == 2);
  CHECK(m.sleeps[0].value == 0);
  CHECK(m.sleeps[1].value == 1);
  REQUIRE(m.resets.size() == 2);
  CHECK(m.resets[0].value == 0);
  const size_t woken = first_step_from(m.steps, m.sleeps[0].cycle), after_reset = first_step_from(m.steps, m.resets[0].cycle);
  REQUIRE(woken > 20);                   // the first note played
  REQUIRE(after_reset - woken > 20);     // and the second
  REQUIRE(m.steps.size() - after_reset > 20);  // and the third
  CHECK(m.steps[woken].rise_cycle > m.sleeps[1].cycle);  // none while asleep: the note stopped before SLEEP fell
  const uint64_t second = m.steps[woken].rise_cycle;
  CHECK(second - m.sleeps[1].cycle >= 1000 * 16u);
  CHECK(second - m.sleeps[1].cycle <= 1500 * 16u);
  const uint64_t pulse = m.resets[1].cycle - m.resets[0].cycle;
  CHECK(pulse >= 10 * 16u);
  CHECK(pulse < 100 * 16u);
  const uint64_t third = m.steps[after_reset].rise_cycle;  // none in reset: the note stopped before
  std::printf("driver acts: after wake the note stepped %.3f ms later; RESET low %.1f us, then the note %.3f ms later\n",
              double(second - m.sleeps[1].cycle) / kMsCycles, double(pulse) / 16, double(third - m.resets[1].cycle) / kMsCycles);
  CHECK(third - m.resets[1].cycle >= 1000 * 16u);
  CHECK(third - m.resets[1].cycle <= 1500 * 16u);
  CHECK(lost_steps(t, 2) == 0);
}

TEST_CASE("driver: uno refuses bad driver settings with config, length or motor and keeps playing", "[driver]") {
  DriverRig r("driver-refused", {"--sleep-pin", "1=14"});
  // Counted from here: hello's first bytes may meet the firmware's receiver still off at power-up
  // and leave a torn frame behind.
  const auto before = r.b.status();
  REQUIRE(before);
  r.play(0, kPeriod1k);
  r.wait(0.02);
  const std::vector<sc::DriverBody> bad = {
      {0, 20, -1, sc::kIdleNone, 100, 1000},           // the Uno has pins 0-19
      {0, 2, -1, sc::kIdleNone, 100, 1000},            // motor 0's STEP
      {0, -1, 6, sc::kIdleNone, 100, 1000},            // motor 1's DIR
      {0, 8, -1, sc::kIdleNone, 100, 1000},            // the shared ENABLE
      {0, 9, -1, sc::kIdleNone, 100, 1000},            // motor 0's switch
      {0, 1, -1, sc::kIdleNone, 100, 1000},            // UART TX
      {0, -1, -1, sc::kIdleSleep, 100, 1000},          // idle sleep without a SLEEP pin
      {0, 14, 14, sc::kIdleNone, 100, 1000},           // one pin for SLEEP and RESET
      {0, 14, -1, 3, 100, 1000},                       // no such idle setting
      {0, 14, -1, sc::kIdleSleep, 100, sc::kWakeUsMax + 1},
  };
  for (const auto &d : bad) r.b.send(driver_payload(d));
  auto short_frame = driver_payload(bad[0]);
  short_frame.pop_back();
  r.b.send(short_frame);
  r.b.send(driver_payload({4, 14, -1, sc::kIdleNone, 100, 1000}));
  r.b.send(driver_payload({1, 14, -1, sc::kIdleNone, 100, 1000}));  // taken: A0 is motor 1's SLEEP now
  r.b.send(driver_payload({0, 14, -1, sc::kIdleNone, 100, 1000}));  // ... so not motor 0's
  const auto errors = e2e::read_replies(r.b, sc::kMsgError, bad.size() + 3);
  r.wait(0.02);
  const auto status = r.b.status();
  r.play(0, 0);
  const tr::Trace t = r.finish();
  std::vector<uint8_t> want(bad.size(), sc::kErrConfig);
  for (uint8_t code : {sc::kErrLength, sc::kErrMotor, sc::kErrConfig}) want.push_back(code);
  std::vector<uint8_t> codes;
  for (const auto &e : errors) {
    codes.push_back(e[1]);
    CHECK(e[2] == sc::kMsgDriver);
  }
  CHECK(codes == want);
  REQUIRE(status);
  CHECK(status->head.frames_bad - before->head.frames_bad == static_cast<int>(bad.size()) + 3);
  CHECK(status->motors[0].flags & sc::kMotorSounding);  // still playing after the refusals
  // one note, every step on its grid: no gap, no hiccup while the frames were refused
  const auto &s = t.motor[0].steps;
  REQUIRE(notes_of(s).size() == 1);
  REQUIRE(s.size() > 40);
  uint64_t worst = 0;
  for (size_t k = 1; k < s.size(); ++k) {
    const uint64_t d = s[k].rise_cycle - s[k - 1].rise_cycle;
    worst = std::max(worst, d > 16000 ? d - 16000 : 16000 - d);
  }
  CHECK(worst <= 160);  // 1 % of the period
  CHECK(t.motor[1].sleeps.empty());  // motor 1's SLEEP stayed high (configured, never asleep)
  CHECK(lost_steps(t, 0) == 0);
}

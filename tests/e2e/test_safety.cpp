// test_safety.cpp: the real firmware on the virtual board keeps the motors safe: endstop
// bounce-back (clean and chattering switches), soft limits, onset direction, watchdog,
// stop-all, and garbage on the line (uno and mega).
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

const uint16_t kDefaultWatchdogMs = 300;  // PROTOCOL.md: the watchdog's power-up timeout
// A single step interval may move by the edge timing the firmware promises (a few us: 1 % of
// a 2 kHz period); the mean over 8 steps, i.e. the frequency, by 0.1 % at most.
const double kIntervalTolerance = 0.01;
const double kMeanTolerance = 0.001;

// A virtual board (no pacing, traced), and a host session on it that has said hello.
struct Rig {
  std::string trace_path;
  e2e::StoppableVboard vb;
  Board b;
  Caps caps;

  // Starts `board` with the extra vboard options, tracing to <scratch>/<name>.csv.
  Rig(const std::string &name, const std::string &board, const std::vector<std::string> &extra)
      : trace_path(e2e::scratch(name + ".csv")),
        vb(vboard_args(board, trace_path, extra)),
        b(open_link(vb.pty())),
        caps(b.hello()) {}

  // The vboard command line: no pacing, a generous simulated-time cap, trace, quiet.
  static std::vector<std::string> vboard_args(const std::string &board, const std::string &trace,
                                              const std::vector<std::string> &extra) {
    std::vector<std::string> a{"--board", board, "--no-pacing", "--seconds", "120", "--trace", trace, "--quiet"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }

  // Ticks for a duration in seconds on this board.
  uint32_t ticks(double seconds) const { return e2e::ticks_for(seconds, caps.f_cpu_hz); }

  // Stops the board, requires a clean exit (no AVR crash) and reads the trace.
  tr::Trace finish() {
    const int rc = vb.stop();
    INFO("stepchoir-vboard exit status " << rc << " (2 = the AVR crashed)");
    REQUIRE(rc == 0);
    return tr::read_trace(trace_path);
  }

  // What play_tone leaves: the period sent, the board's status after the note, the trace.
  struct Played {
    uint32_t period_q8;
    Status status;
    tr::Trace trace;
  };

  // With the watchdog off, configures `motor` for `travel_steps`, plays `hz` on it for
  // `seconds` of board time, silences it, reads the status and finishes the run.
  Played play_tone(uint8_t motor, uint32_t travel_steps, double hz, double seconds) {
    b.send(e2e::watchdog_payload(0));
    b.send(config_payload(e2e::motor_config(motor, travel_steps)));
    const uint32_t period_q8 = hz_to_period_q8(hz, caps.f_cpu_hz);
    const uint32_t t0 = e2e::board_ticks(b);
    b.send(e2e::tone_payload(motor, period_q8));
    e2e::wait_board_time(b, t0 + ticks(seconds));
    b.send(e2e::tone_payload(motor, 0));
    const auto st = b.status();
    REQUIRE(st);
    return {period_q8, *st, finish()};
  }
};

// Presses (P) and reversal steps (R) of one motor in time order, e.g. "PRPRPR"; only presses
// followed by at least one step count (the note may end right after a press).
std::string press_reversal_sequence(const tr::MotorTrace &m, const std::vector<size_t> &reversals) {
  std::vector<std::pair<uint64_t, char>> events;
  for (uint64_t c : e2e::press_cycles(m))
    if (!m.steps.empty() && c < m.steps.back().rise_cycle) events.push_back({c, 'P'});
  for (size_t i : reversals) events.push_back({m.steps[i].rise_cycle, 'R'});
  std::stable_sort(events.begin(), events.end(),
                   [](const auto &a, const auto &b) { return a.first < b.first; });
  std::string s;
  for (const auto &e : events) s += e.second;
  return s;
}

// Largest relative deviation from period_cycles of the step intervals at each reversal: the
// one before the turn, the one across it and the one after it.
double worst_interval_deviation(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
                                double period_cycles) {
  double worst = 0;
  for (size_t r : reversals) {
    for (size_t k = std::max<size_t>(1, r - 1); k <= std::min(steps.size() - 1, r + 1); ++k) {
      const double interval = double(steps[k].rise_cycle - steps[k - 1].rise_cycle);
      worst = std::max(worst, std::abs(interval - period_cycles) / period_cycles);
    }
  }
  return worst;
}

// Largest relative change between the mean step interval over the n steps up to a reversal
// and over the n steps from it: the frequency before and after the turn.
double worst_mean_interval_change(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
                                  size_t n = 8) {
  double worst = 0;
  for (size_t r : reversals) {
    if (r < n + 1 || r + n >= steps.size()) continue;
    const double before = double(steps[r - 1].rise_cycle - steps[r - 1 - n].rise_cycle) / n;
    const double after = double(steps[r + n].rise_cycle - steps[r].rise_cycle) / n;
    worst = std::max(worst, std::abs(after - before) / before);
  }
  return worst;
}

// Largest relative deviation from period_cycles of any step interval of the note: timing
// jitter everywhere, to tell apart from jitter at the reversals.
double worst_interval_deviation_anywhere(const std::vector<tr::Step> &steps, double period_cycles) {
  double worst = 0;
  for (size_t k = 1; k < steps.size(); ++k)
    worst = std::max(worst, std::abs(double(steps[k].rise_cycle - steps[k - 1].rise_cycle) - period_cycles) /
                                period_cycles);
  return worst;
}

// Reversals whose turning step (the step before the reversal) is not within `slack` steps of
// either end of a rail of `rail` steps.
size_t reversals_away_from_ends(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
                                int64_t rail, int64_t slack) {
  size_t away = 0;
  for (size_t r : reversals) {
    const int64_t p = steps[r - 1].position;
    if (std::abs(p) > slack && std::abs(p - rail) > slack) ++away;
  }
  return away;
}

// Plays 2000 Hz on motor 0 for 2 s on a 400-step rail whose switches act before the firmware's
// soft limits (firmware travel 800), and checks each press gives exactly one reversal, at the
// end, in time, at the same frequency.
void check_bounce_back(const std::string &board, uint32_t chatter_us) {
  const int64_t kRail = 400;
  std::vector<std::string> extra{"--travel-steps", std::to_string(kRail)};
  if (chatter_us) extra.insert(extra.end(), {"--chatter-us", std::to_string(chatter_us), "--seed", "7"});
  Rig r("safety-bounce-" + board + (chatter_us ? "-chatter" : ""), board, extra);
  REQUIRE(!r.caps.endstops.empty());
  REQUIRE(r.caps.endstops[0] != 0);  // motor 0 has a switch
  const Rig::Played p = r.play_tone(0, 2 * kRail, 2000.0, 2.0);
  const uint32_t period_q8 = p.period_q8;
  const Status &st = p.status;
  const tr::Trace &t = p.trace;

  const tr::MotorTrace &m = t.motor[0];
  const std::vector<size_t> rev = tr::reversal_indices(m.steps);
  const std::string seq = press_reversal_sequence(m, rev);
  const size_t presses = size_t(std::count(seq.begin(), seq.end(), 'P'));
  std::string alternating;
  for (size_t i = 0; i < presses; ++i) alternating += "PR";
  const double deviation = worst_interval_deviation(m.steps, rev, period_q8 / 256.0);
  const double mean_change = worst_mean_interval_change(m.steps, rev);
  const double deviation_anywhere = worst_interval_deviation_anywhere(m.steps, period_q8 / 256.0);
  const int64_t overshoot = tr::max_overshoot_steps(m.steps, kRail);
  std::printf("%s bounce-back (chatter %u us): %zu steps, %zu presses, %zu reversals, %zu bounce toggles, "
              "overshoot %lld, status reversals %u; worst step interval deviation %.4f %% at reversals (%.4f %% "
              "anywhere), worst 8-step mean interval change across a reversal %.4f %%\n",
              board.c_str(), chatter_us, m.steps.size(), presses, rev.size(), m.bounces.size(),
              (long long)overshoot, st.head.reversals, deviation * 100, deviation_anywhere * 100, mean_change * 100);
  INFO(board << ", chatter " << chatter_us << " us: presses/reversals in time order " << seq);
  REQUIRE(m.steps.size() > 3000);
  REQUIRE(presses >= 8);
  CHECK(rev.size() == presses);
  CHECK(seq == alternating);  // each press is followed by exactly one reversal before the next press
  CHECK(st.head.reversals == rev.size());
  // The firmware reads the switch once a step: a press that bounces open before the next read
  // is seen a few steps late (measured: up to 6 with 3 ms of chatter); its soft margin is 8.
  CHECK(overshoot <= 8);
  CHECK(reversals_away_from_ends(m.steps, rev, kRail, 8) == 0);
  INFO("worst step interval deviation at a reversal: " << deviation * 100 << " % (anywhere in the note: "
                                                         << deviation_anywhere * 100 << " %)");
  CHECK(deviation <= kIntervalTolerance);   // before, across and after the turn: the played period
  CHECK(mean_change <= kMeanTolerance);  // the frequency is the same after the turn
  if (chatter_us) CHECK(m.bounces.size() >= presses);  // the contacts really chattered
}

// Plays a note with the watchdog at timeout_ms, then sends nothing: the last frame is a clock
// request, whose ticks are the board time the silence began. Checks the stop, ENABLE, status.
void check_watchdog(uint16_t timeout_ms) {
  Rig r("safety-watchdog-" + std::to_string(timeout_ms), "uno", {});
  if (timeout_ms != kDefaultWatchdogMs) r.b.send(e2e::watchdog_payload(timeout_ms));
  const uint32_t period_q8 = hz_to_period_q8(2000.0, r.caps.f_cpu_hz);
  const uint32_t at = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at + r.ticks(0.002));
  const uint32_t t_last = e2e::board_ticks(r.b, 0x21);  // the last frame for a while
  // no pacing: the board runs faster than wall time, so twice the timeout is plenty
  std::this_thread::sleep_for(std::chrono::milliseconds(2 * (timeout_ms + 50)));
  const auto status_reply = r.b.status(5000);  // the first frame after the silence
  REQUIRE(status_reply);
  const Status st = *status_reply;
  const uint32_t t_after = e2e::board_ticks(r.b, 0x22);
  const tr::Trace t = r.finish();
  const double ticks_per_ms = r.caps.f_cpu_hz / 1000.0;
  INFO("the host was silent for " << (t_after - t_last) / ticks_per_ms << " ms of board time");
  REQUIRE(t_after - t_last > r.ticks((timeout_ms + 20) / 1000.0));  // precondition: silence past the timeout

  const tr::MotorTrace &m = t.motor[0];
  REQUIRE(m.steps.size() > 100);
  const int64_t offset = e2e::cycle_offset(m, at);  // board ticks -> trace cycles
  const double silence_from = double(t_last) + double(offset);
  const double last_step_ms = (double(m.steps.back().rise_cycle) - silence_from) / ticks_per_ms;
  const tr::LevelChange *enabled = nullptr;
  for (const auto &e : m.enables)
    if (e.cycle < m.steps.front().rise_cycle && e.value == 0) enabled = &e;
  const tr::LevelChange *disabled = e2e::first_enable_change(m, uint64_t(silence_from), 1);
  const double disabled_ms = disabled ? (double(disabled->cycle) - silence_from) / ticks_per_ms : -1;
  std::printf("watchdog %u ms: last step %.3f ms, ENABLE high %.3f ms after the last frame (board ticks + %lld "
              "= trace cycles); status flags 0x%02x, last error %u\n",
              timeout_ms, last_step_ms, disabled_ms, (long long)offset, st.head.flags, st.head.last_error);
  INFO("watchdog " << timeout_ms << " ms: last step " << last_step_ms << " ms after the last frame, ENABLE high after "
                   << disabled_ms << " ms");
  CHECK(enabled);                                // the note had the drivers on (ENABLE low)
  CHECK(last_step_ms >= timeout_ms - 1.0);       // the note kept playing until the timeout
  CHECK(last_step_ms <= timeout_ms + 10.0);      // and stopped within 10 ms of it
  REQUIRE(disabled);                             // ENABLE went high: drivers off
  CHECK(disabled_ms >= timeout_ms - 1.0);
  CHECK(disabled_ms <= timeout_ms + 10.0);
  CHECK(m.steps.back().rise_cycle <= disabled->cycle);  // no step after the drivers were disabled
  // the first frame after the trip is the status request: it must report the trip
  CHECK((st.head.flags & sc::kStatusWatchdogTripped) != 0);
  CHECK((st.head.flags & sc::kStatusDriversEnabled) == 0);
  CHECK(st.head.last_error == sc::kErrWatchdog);
  REQUIRE(st.motors.size() == r.caps.motor_count);
  CHECK((st.motors[0].flags & sc::kMotorSounding) == 0);
}

// A busy board: motor 0 plays `hz`. With the watchdog off, the board must still answer a clock
// request and obey stop-all; with the watchdog at 100 ms and no frame after the note's `at`
// frame, the watchdog must stop the motor.
void check_busy(double hz) {
  const double ticks_per_ms = 16000.0;
  {
    Rig r("safety-busy-stopall-uno-" + std::to_string(int(hz)), "uno", {});
    r.b.send(e2e::watchdog_payload(0));
    const uint32_t period_q8 = hz_to_period_q8(hz, r.caps.f_cpu_hz);
    REQUIRE(period_q8 >= sc::kPeriodQ8Min);  // a period every message may carry
    const uint32_t at = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
    // Past `at` (however fast the unpaced simulation runs on a busy machine), then more.
    e2e::wait_board_time(r.b, at + static_cast<uint32_t>(20 * ticks_per_ms));
    r.b.send({sc::kMsgClockReq, 0x71});
    const auto clock = r.b.wait_reply(sc::kMsgClock, 500);  // ~2 s of board time
    r.b.send({sc::kMsgStopAll});
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const auto st = r.b.status(500);
    const tr::Trace t = r.finish();
    const tr::MotorTrace &m = t.motor[0];
    REQUIRE(m.steps.size() > 100);
    const double played_ms = double(m.steps.back().rise_cycle - m.steps.front().rise_cycle) / ticks_per_ms;
    const double quiet_ms = double(t.end_cycle - m.steps.back().rise_cycle) / ticks_per_ms;
    std::printf("uno %.0f Hz, stop-all: %zu steps over %.1f ms; clock reply %s, status reply %s; motor quiet for the "
                "last %.1f ms of the run (`at` tick %u)\n",
                hz, m.steps.size(), played_ms, clock ? "yes" : "NO", st ? "yes" : "NO", quiet_ms, at);
    INFO(hz << " Hz: the motor was quiet for the last " << quiet_ms << " ms of the run");
    CHECK(clock);            // the board answers while a motor plays
    CHECK(st);
    CHECK(quiet_ms > 50.0);  // stop-all was obeyed: the motor did not play to the end of the run
  }
  {
    Rig r("safety-busy-watchdog-uno-" + std::to_string(int(hz)), "uno", {});
    r.b.send(e2e::watchdog_payload(100));
    const uint32_t period_q8 = hz_to_period_q8(hz, r.caps.f_cpu_hz);
    const uint32_t at = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);  // the last frame
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    const tr::Trace t = r.finish();
    const tr::MotorTrace &m = t.motor[0];
    REQUIRE(m.steps.size() > 100);
    const int64_t offset = e2e::cycle_offset(m, at);
    // the `at` frame was decoded before `at`: the watchdog must stop the motor by at + 100 ms
    const double run_after_at_ms = (double(t.end_cycle) - double(at + offset)) / ticks_per_ms;
    const double last_step_ms = (double(m.steps.back().rise_cycle) - double(at + offset)) / ticks_per_ms;
    std::printf("uno %.0f Hz, watchdog 100 ms: last step %.1f ms after the note's `at` time, run lasted %.1f ms "
                "after it\n",
                hz, last_step_ms, run_after_at_ms);
    INFO(hz << " Hz, watchdog 100 ms: last step " << last_step_ms << " ms after the `at` time");
    REQUIRE(run_after_at_ms > 150.0);  // precondition: the board ran past the timeout
    CHECK(last_step_ms <= 110.0);
  }
}

}  // namespace

TEST_CASE("safety: uno motor 0 bounces back off its switch - one reversal per press") {
  check_bounce_back("uno", 0);
}

TEST_CASE("safety: mega motor 0 bounces back off its min and max switches - one reversal per press") {
  check_bounce_back("mega", 0);
}

TEST_CASE("safety: uno motor 0 with 3 ms switch chatter: still exactly one reversal per press") {
  check_bounce_back("uno", 3000);
}

TEST_CASE("safety: mega motor 0 with 3 ms switch chatter: still exactly one reversal per press") {
  check_bounce_back("mega", 3000);
}

TEST_CASE("safety: uno motor A (no switch) reverses at its soft limits and never leaves the rail") {
  const int64_t kRail = 300;
  Rig r("safety-soft-uno", "uno", {"--travel-steps", std::to_string(kRail)});
  REQUIRE(r.caps.endstops.size() == 4);
  REQUIRE(r.caps.endstops[3] == 0);  // motor A: no switch
  const Rig::Played p = r.play_tone(3, uint32_t(kRail), 2000.0, 1.0);
  const uint32_t period_q8 = p.period_q8;
  const Status &st = p.status;
  const tr::Trace &t = p.trace;

  const tr::MotorTrace &m = t.motor[3];
  const std::vector<size_t> rev = tr::reversal_indices(m.steps);
  const int64_t overshoot = tr::max_overshoot_steps(m.steps, kRail);
  const double deviation = worst_interval_deviation(m.steps, rev, period_q8 / 256.0);
  const double mean_change = worst_mean_interval_change(m.steps, rev);
  const double deviation_anywhere = worst_interval_deviation_anywhere(m.steps, period_q8 / 256.0);
  std::printf("uno soft limits: %zu steps, %zu reversals, overshoot %lld; worst step interval deviation %.4f %% at "
              "reversals (%.4f %% anywhere), worst 8-step mean interval change across a reversal %.4f %%\n",
              m.steps.size(), rev.size(), (long long)overshoot, deviation * 100, deviation_anywhere * 100,
              mean_change * 100);
  REQUIRE(m.steps.size() > 1500);
  CHECK(rev.size() >= 5);
  CHECK(overshoot <= 1);
  CHECK(reversals_away_from_ends(m.steps, rev, kRail, 1) == 0);  // turns only at the ends
  CHECK(m.endstop_changes.empty());
  CHECK(st.head.reversals == rev.size());
  INFO("worst step interval deviation at a reversal: " << deviation * 100 << " % (anywhere in the note: "
                                                         << deviation_anywhere * 100 << " %)");
  CHECK(deviation <= kIntervalTolerance);
  CHECK(mean_change <= kIntervalTolerance);
}

TEST_CASE("safety: uno note onset after a switch reversal heads away from the end it hit") {
  // 600-step rail, carriage at 100; the firmware believes mid travel (1600 of 3200) until a
  // switch recalibrates it, and either way its first reversal is at a switch.
  const int64_t kRail = 600;
  Rig r("safety-onset-uno", "uno", {"--travel-steps", std::to_string(kRail), "--start-position", "100"});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(1000.0, r.caps.f_cpu_hz);
  r.b.send(e2e::tone_payload(0, period_q8));
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (;;) {
    const auto st = r.b.status();
    REQUIRE(st);
    if (st->head.reversals >= 1) break;
    REQUIRE(std::chrono::steady_clock::now() < give_up);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r.b.send(e2e::tone_payload(0, 0));
  // A sounding motor takes a command at its next edge when that is near (within 256 us,
  // kVisitMarginTicks): the status right after may still say sounding. Silent within 20 ms of
  // wall time (a status round trip through the pty takes up to a few ms on a loaded machine).
  const auto silence_by = std::chrono::steady_clock::now() + std::chrono::milliseconds(20);
  bool silent = false;
  while (!silent) {
    const auto between = r.b.status();
    REQUIRE(between);
    silent = (between->motors[0].flags & sc::kMotorSounding) == 0;
    if (!silent && std::chrono::steady_clock::now() > silence_by) break;
  }
  CHECK(silent);
  e2e::wait_board_time(r.b, e2e::board_ticks(r.b) + r.ticks(0.02));  // 20 ms of silence
  r.b.send(e2e::tone_payload(0, period_q8));
  const uint32_t t2 = e2e::board_ticks(r.b, 0x42);
  e2e::wait_board_time(r.b, t2 + r.ticks(0.05));
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();

  const tr::MotorTrace &m = t.motor[0];
  REQUIRE(!m.endstop_changes.empty());
  const tr::LevelChange &press = m.endstop_changes.front();
  REQUIRE(press.value == 1);
  const bool hit_min = press.position <= kRail / 2;
  // the second note starts after the one long gap between steps (the silence)
  size_t second = 0, gaps = 0;
  for (size_t k = 1; k < m.steps.size(); ++k)
    if (m.steps[k].rise_cycle - m.steps[k - 1].rise_cycle > 3 * period_q8 / 256) second = k, ++gaps;
  REQUIRE(gaps == 1);
  // the switch was hit during the first note (by its last step at the latest: the host silences
  // the motor as soon as status shows the reversal, which may be before the next step)
  REQUIRE(press.cycle <= m.steps[second - 1].rise_cycle);
  REQUIRE(m.steps.size() - second >= 20);
  const int64_t stop_position = m.steps[second - 1].position;
  const int expected_step = hit_min ? +1 : -1;  // away from the end it hit
  size_t wrong = 0;
  for (size_t k = second; k < second + 20; ++k)
    if (m.steps[k].position - (k == second ? stop_position : m.steps[k - 1].position) != expected_step) ++wrong;
  std::printf("uno onset: switch hit at %lld, stopped at %lld, new note's first step to %lld\n",
              (long long)press.position, (long long)stop_position, (long long)m.steps[second].position);
  INFO("switch pressed at position " << press.position << ", carriage stopped at " << stop_position
                                     << ", the new note's first step went to " << m.steps[second].position);
  REQUIRE(std::abs(stop_position - press.position) < kRail / 2);  // stopped near the end it hit
  CHECK(m.steps[second].position - stop_position == expected_step);
  CHECK(wrong == 0);  // its first 20 steps all head away from that end
}

TEST_CASE("safety: uno board clock: `at` notes start on their tick") {
  // Board ticks count from when the firmware started its timer, a fixed ~1 ms after reset, so
  // ticks and trace cycles differ by one constant: two `at` notes must show the same offset.
  Rig r("safety-clock-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(1000.0, r.caps.f_cpu_hz);
  // the default lead covers a busy machine's round trip; the second note starts later still
  const uint32_t at1 = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
  const uint32_t at2 = e2e::start_note_at(r.b, 1, period_q8, r.caps.f_cpu_hz, 0.1);
  e2e::wait_board_time(r.b, at2 + r.ticks(0.02));
  r.b.send(e2e::tone_payload(0, 0));
  r.b.send(e2e::tone_payload(1, 0));
  const tr::Trace t = r.finish();
  REQUIRE(!t.motor[0].steps.empty());
  REQUIRE(!t.motor[1].steps.empty());
  // each note's offset from its grid, not its first edge alone: one edge may wait behind an
  // interrupt (20 cycles or so)
  const int64_t offset1 = e2e::grid_cycle_offset(t.motor[0], at1, period_q8);
  const int64_t offset2 = e2e::grid_cycle_offset(t.motor[1], at2, period_q8);
  std::printf("uno clock: trace cycles - board ticks = %lld and %lld for two `at` notes\n", (long long)offset1,
              (long long)offset2);
  CHECK(std::abs(offset1 - offset2) <= 16);  // within 1 us
  CHECK(offset1 > 0);
  CHECK(offset1 < 16000 * 5);  // the timer starts within a few ms of reset
}

TEST_CASE("safety: uno watchdog (300 ms default) stops the note and disables the drivers") {
  check_watchdog(kDefaultWatchdogMs);
}

TEST_CASE("safety: uno watchdog set to 100 ms stops the note within 100 ms") { check_watchdog(100); }

TEST_CASE("safety: uno stop-all silences a 4 kHz note within 400 us and disables the drivers (4 tries)") {
  Rig r("safety-stopall-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(4000.0, r.caps.f_cpu_hz);
  const double ticks_per_us = r.caps.f_cpu_hz / 1e6;
  const double byte_ticks = 10.0 * r.caps.f_cpu_hz / sc::kBaud;  // one 8N1 byte on the wire
  // clock request A, stop-all, clock request B back to back: the stop-all frame is complete on
  // the wire this long after A is
  const double stop_end_after_a = byte_ticks * double(frame({sc::kMsgStopAll}).size());
  struct Try {
    uint32_t at, t_a, t_b;
    uint8_t status_flags, motor_flags;
  };
  std::vector<Try> tries;
  for (int i = 0; i < 4; ++i) {  // the host's timing falls at a different phase of the steps each time
    Try k{};
    k.at = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
    e2e::wait_board_time(r.b, k.at + r.ticks(0.02 + 0.0013 * i));
    e2e::send_back_to_back(r.b, {{sc::kMsgClockReq, 0x31}, {sc::kMsgStopAll}, {sc::kMsgClockReq, 0x32}});
    const auto clocks = e2e::read_replies(r.b, sc::kMsgClock, 2);
    REQUIRE(clocks[0][1] == 0x31);
    REQUIRE(clocks[1][1] == 0x32);
    k.t_a = sc::get_u32(&clocks[0][2]);
    k.t_b = sc::get_u32(&clocks[1][2]);
    const auto st = r.b.status();
    REQUIRE(st);
    REQUIRE(st->motors.size() == r.caps.motor_count);
    k.status_flags = st->head.flags;
    k.motor_flags = st->motors[0].flags;
    tries.push_back(k);
  }
  const tr::Trace t = r.finish();

  const tr::MotorTrace &m = t.motor[0];
  REQUIRE(m.steps.size() > 200);
  const int64_t offset = e2e::cycle_offset(m, tries[0].at);  // board ticks -> trace cycles
  for (size_t i = 0; i < tries.size(); ++i) {
    const Try &k = tries[i];
    const double t_stop = double(k.t_a) + double(offset) + stop_end_after_a;  // trace cycles
    // this try's last step: the next try's note starts on its `at` tick (give or take a few cycles)
    const uint64_t next_start =
        i + 1 < tries.size() ? uint64_t(tries[i + 1].at + offset) - r.ticks(0.001) : t.end_cycle + 1;
    const tr::Step *last = nullptr;
    for (const auto &s : m.steps)
      if (s.rise_cycle < next_start) last = &s;
    REQUIRE(last);
    const double last_us = (double(last->rise_cycle) - t_stop) / ticks_per_us;
    const tr::LevelChange *disabled = e2e::first_enable_change(m, uint64_t(k.t_a + offset), 1);
    const double disabled_us = disabled ? (double(disabled->cycle) - t_stop) / ticks_per_us : 1e9;
    std::printf("uno stop-all try %zu: last step %.2f us, ENABLE high %.2f us after the stop-all frame ended; the "
                "clock request right after it decoded %.1f us after it ended (60 us of wire; board ticks + %lld = "
                "trace cycles)\n",
                i, last_us, disabled_us, (double(k.t_b) + double(offset) - t_stop) / ticks_per_us, (long long)offset);
    INFO("try " << i << ": last step " << last_us << " us, ENABLE high " << disabled_us
                << " us after the stop-all frame ended");
    CHECK(last_us >= -2.0 * period_q8 / 256.0 / ticks_per_us);  // still playing when the stop came
    CHECK(last_us <= 400.0);  // measured about 200 us: the main loop decodes the frame after
    CHECK(disabled_us <= 400.0);  // the bytes queued before it
    CHECK((k.status_flags & sc::kStatusDriversEnabled) == 0);
    CHECK((k.motor_flags & sc::kMotorSounding) == 0);
  }
}

TEST_CASE("safety: uno refuses 10 kHz (above the firmware's range) and keeps answering") {
  Rig r("safety-refuse-uno", "uno", {});
  r.b.send(e2e::tone_payload(0, hz_to_period_q8(10000.0, r.caps.f_cpu_hz)));
  const auto err = r.b.wait_reply(sc::kMsgError, 500);
  REQUIRE(err);
  CHECK((*err)[1] == sc::kErrPeriodRange);
  CHECK(r.b.status(500));
  const tr::Trace t = r.finish();
  CHECK(t.motor[0].steps.empty());
}

TEST_CASE("safety: uno playing the shortest period the firmware takes still answers and obeys stop-all") {
  check_busy(16e6 * 256.0 / sc::kPeriodQ8Min);
}

TEST_CASE("safety: uno survives 300 kB of garbage at full speed - hello - status and a tone still right") {
  Rig r("safety-garbage-uno", "uno", {});
  const Caps before = r.caps;
  const std::vector<uint8_t> junk = e2e::garbage_bytes(300000, 20240607);
  const uint32_t t_junk = e2e::board_ticks(r.b, 0x51);
  for (size_t at = 0; at < junk.size(); at += 4096)
    REQUIRE(r.b.link().write(junk.data() + at, std::min<size_t>(4096, junk.size() - at)));
  // resync, then hello (as Board::hello does, counting the tries): answered once the garbage is
  // through; a try gets 2 s of wall time, several seconds of board time
  std::optional<Caps> answer;
  int tries = 0;
  while (!answer && tries < 3) {
    ++tries;
    r.b.resync();
    r.b.send({sc::kMsgHello});
    if (const auto reply = r.b.wait_reply(sc::kMsgCaps, 2000)) answer = parse_caps(reply->data(), reply->size());
  }
  REQUIRE(answer);
  const Caps after = *answer;
  const uint32_t t_hello = e2e::board_ticks(r.b, 0x52);
  const auto st = r.b.status();
  REQUIRE(st);
  std::printf("uno garbage: %zu bytes, hello answered at try %d, %.3f s of board time after the garbage began; "
              "frames ok %u bad %u, uart overruns %u, last error %u\n",
              junk.size(), tries, double(t_hello - t_junk) / r.caps.f_cpu_hz, st->head.frames_ok,
              st->head.frames_bad, st->head.uart_overruns, st->head.last_error);
  // the board really took every byte in: 300 kB at 1 Mbaud are 3 s on the wire
  CHECK(double(t_hello - t_junk) >= 0.95 * junk.size() * 10.0 / sc::kBaud * r.caps.f_cpu_hz);
  CHECK(after.protocol_version == sc::kProtocolVersion);
  CHECK(after.protocol_version == before.protocol_version);
  CHECK(after.motor_count == 4);
  CHECK(after.motor_count == before.motor_count);
  CHECK(after.f_cpu_hz == before.f_cpu_hz);
  CHECK(after.queue_size == before.queue_size);
  CHECK(after.endstops == std::vector<uint8_t>{7, 7, 7, 0});
  CHECK(after.board_name == "uno_cnc_shield_v3");
  CHECK(st->head.frames_bad > 0);

  const uint32_t period_q8 = hz_to_period_q8(440.0, r.caps.f_cpu_hz);
  const uint32_t t_tone = e2e::board_ticks(r.b, 0x53);
  r.b.send(e2e::tone_payload(0, period_q8));
  e2e::wait_board_time(r.b, t_tone + r.ticks(0.6));  // the clock requests keep the watchdog fed
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();

  size_t early = 0;  // steps before the tone: the garbage must never have moved a motor
  for (const auto &m : t.motor)
    for (const auto &s : m.steps)
      if (s.rise_cycle < t_tone) ++early;
  CHECK(early == 0);
  const auto edges = tr::rise_cycles_in_window(t.motor[0].steps, t_tone + r.ticks(0.02), t_tone + r.ticks(0.6));
  REQUIRE(edges.size() >= 200);
  const tr::PitchFit f = tr::fit_edges(edges, period_q8 / 256.0, t.f_cpu_hz);
  std::printf("uno tone after garbage: %zu edges, %.5f cents, p99 %.3f us\n", edges.size(), f.cents_error,
              f.residual_p99_us);
  INFO("tone after the garbage: " << f.cents_error << " cents, p99 residual " << f.residual_p99_us << " us");
  CHECK(std::abs(f.cents_error) < 0.05);
}

TEST_CASE("safety: uno onset ramp - the period shrinks by the configured step from the start speed") {
  Rig r("safety-ramp-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  sc::ConfigBody c = e2e::motor_config(1, 3200);
  const uint32_t target_q8 = hz_to_period_q8(2000.0, r.caps.f_cpu_hz);  // 8000 ticks
  c.start_period_q8 = hz_to_period_q8(500.0, r.caps.f_cpu_hz);          // 32000 ticks
  c.accel_q8 = 1000u << sc::kPeriodFracBits;                            // 1000 ticks a step
  r.b.send(config_payload(c));
  REQUIRE_FALSE(r.b.wait_reply(sc::kMsgError, 200));
  const uint32_t at = e2e::start_note_at(r.b, 1, target_q8, r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at + r.ticks(0.1));
  r.b.send(e2e::tone_payload(1, 0));
  const tr::Trace t = r.finish();
  const auto &steps = t.motor[1].steps;
  REQUIRE(steps.size() > 40);
  // intervals: 31000, 30000, ... (the first step uses the start period, each next one 1000
  // ticks less) until the target, then the target
  std::vector<int64_t> interval;
  for (size_t i = 1; i < steps.size(); ++i) interval.push_back(int64_t(steps[i].rise_cycle - steps[i - 1].rise_cycle));
  const int64_t start = c.start_period_q8 >> sc::kPeriodFracBits, target = target_q8 >> sc::kPeriodFracBits;
  const int64_t ramp = c.accel_q8 >> sc::kPeriodFracBits;
  size_t ramp_steps = 0;
  for (size_t i = 0; i < interval.size() && interval[i] > target + 100; ++i) {
    INFO("interval " << i << ": " << interval[i]);
    CHECK(std::llabs(interval[i] - (start - ramp * int64_t(i + 1))) <= 64);  // within the edge timing
    ++ramp_steps;
  }
  CHECK(ramp_steps == size_t((start - target) / ramp) - 1);
  for (size_t i = ramp_steps + 1; i < interval.size(); ++i) CHECK(std::llabs(interval[i] - target) <= 64);
}

TEST_CASE("safety: uno overloaded by four fast motors still answers - obeys stop-all and keeps count") {
  // 4 x 3 kHz is more steps than the step ISR can time exactly: edges come late, but the main
  // loop must keep its share (frames, stop-all, watchdog) and positions must stay right.
  Rig r("safety-overload-uno", "uno", {"--travel-steps", "100000", "--start-position", "50000"});
  r.b.send(e2e::watchdog_payload(0));
  sc::ConfigBody c = e2e::motor_config(0, 100000);
  for (uint8_t m = 0; m < 4; ++m) {
    c.motor = m;
    r.b.send(config_payload(c));
  }
  std::vector<sc::PeriodEntry> chord;
  for (uint8_t m = 0; m < 4; ++m) chord.push_back({m, hz_to_period_q8(3000.0, r.caps.f_cpu_hz)});
  r.b.send(periods_payload(chord));
  const uint32_t t0 = e2e::board_ticks(r.b, 3);
  e2e::wait_board_time(r.b, t0 + r.ticks(0.3));
  r.b.send({sc::kMsgClockReq, 0x44});
  const auto clock = r.b.wait_reply(sc::kMsgClock, 2000);
  CHECK(clock);
  r.b.send({sc::kMsgStopAll});
  const auto st = r.b.status(2000);
  REQUIRE(st);
  CHECK((st->head.flags & sc::kStatusDriversEnabled) == 0);
  const tr::Trace t = r.finish();
  for (uint8_t m = 0; m < 4; ++m) {
    INFO("motor " << int(m));
    REQUIRE(!t.motor[m].steps.empty());
    CHECK((st->motors[m].flags & sc::kMotorSounding) == 0);
    // the firmware's count and the carriage agree (both started mid-rail, neither hit an end)
    CHECK(st->motors[m].position_steps - 50000 == t.motor[m].steps.back().position - 50000);
    // nothing after stop-all: the last step comes before the status reply's board time
    CHECK(t.motor[m].steps.size() < 3000u * 2u);
  }
}

TEST_CASE("safety: uno with four motors at the top of the range still stops on the watchdog") {
  // MIDI 105-108 on all four motors, 15,400 steps a second: more than the step ISR can time,
  // so it keeps the main loop out as long as its overload guards allow. When the host goes
  // quiet the watchdog (main loop) must still stop every motor on time.
  Rig r("safety-top-chord-uno", "uno", {"--trace-frames"});
  std::vector<sc::PeriodEntry> chord;
  for (uint8_t m = 0; m < 4; ++m) chord.push_back({m, hz_to_period_q8(note_hz(108 - m), r.caps.f_cpu_hz)});
  r.b.send(periods_payload(chord));  // and then nothing: the host is gone
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  const tr::Trace t = r.finish();
  REQUIRE(!t.frame_ends.empty());
  const uint64_t last_frame = t.frame_ends.back();
  const double watchdog_s = kDefaultWatchdogMs / 1000.0;
  REQUIRE((double(t.end_cycle) - double(last_frame)) / t.f_cpu_hz > watchdog_s + 0.1);  // the run went on past it
  for (int m = 0; m < 4; ++m) {
    INFO("motor " << m);
    REQUIRE(t.motor[m].steps.size() > 100);  // it was playing
    const double after_s = (double(t.motor[m].steps.back().rise_cycle) - double(last_frame)) / t.f_cpu_hz;
    INFO("last step " << after_s * 1000 << " ms after the last frame");
    CHECK(after_s > watchdog_s - 0.01);   // it played on until the watchdog
    CHECK(after_s <= watchdog_s + 0.01);  // and stopped then
    std::printf("top chord uno motor %d: last step %.1f ms after the last frame\n", m, after_s * 1000);
  }
}

TEST_CASE("safety: uno stuck switch - the motor ignores it - reports it and keeps to its travel") {
  // Motor 0's shared switch reads pressed all the time: the first step takes it for an end and
  // turns round; 400 steps later the firmware calls it stuck, undoes the position it set and
  // runs on its soft limits (travel 3200, 8 steps of margin).
  Rig r("safety-stuck-uno", "uno", {"--stuck-switch", "0"});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t at = e2e::start_note_at(r.b, 0, hz_to_period_q8(4000.0, r.caps.f_cpu_hz), r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at + r.ticks(2.5));
  const auto st = r.b.status(1000);
  REQUIRE(st);
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();
  const auto &steps = t.motor[0].steps;
  REQUIRE(steps.size() > 8000);
  const int64_t overshoot = tr::max_overshoot_steps(steps, 3200);
  const std::vector<size_t> rev = tr::reversal_indices(steps);
  std::printf("uno stuck switch: %zu steps, %zu reversals, overshoot %lld, last error %u, motor flags 0x%02x\n",
              steps.size(), rev.size(), (long long)overshoot, st->head.last_error, st->motors[0].flags);
  CHECK(st->head.last_error == sc::kErrEndstopStuck);
  CHECK((st->motors[0].flags & sc::kMotorEndstopFault) != 0);
  CHECK(overshoot <= 8);
  CHECK(rev.size() >= 3);  // it keeps going back and forth on its soft limits
  for (size_t i = 1; i < rev.size(); ++i) {  // after the first (false) turn, only at the ends
    const int64_t p = steps[rev[i] - 1].position;
    INFO("reversal " << i << " at position " << p);
    CHECK((p <= 8 || p >= 3200 - 8));
  }
}

TEST_CASE("safety: mega host killed with SIGKILL mid-chord - every motor stops within the watchdog time") {
  // Five `stepchoir tone` processes (the real host binary, heartbeats and all) each hold one
  // motor of a chord; then all are killed at once with SIGKILL, the way a crash or the kernel
  // would end them. From the board's trace: every motor's last step comes within the default
  // watchdog time (plus one period) of the last frame that reached the board, and the drivers
  // are disabled then.
  const std::string trace_path = e2e::scratch("safety-sigkill-mega.csv");
  e2e::StoppableVboard vb({"--board", "mega", "--seconds", "60", "--trace", trace_path, "--trace-frames", "--quiet"});
  const std::string bin = std::string(STEPCHOIR_VBOARD).substr(0, std::string(STEPCHOIR_VBOARD).rfind('/'));
  const double hz[] = {220.0, 277.18, 329.63, 440.0, 554.37};
  std::vector<std::unique_ptr<stepchoir::ChildProcess>> hosts;
  for (int m = 0; m < 5; ++m) {
    // One process at a time on the link: each greets the board, starts its note, then only
    // sends heartbeats. Wait for the note before the next one opens the port: the board does
    // not reset on open here, so each waits Board::kBootWaitMs for capabilities that do not
    // come, then asks.
    hosts.push_back(std::make_unique<stepchoir::ChildProcess>(
        std::vector<std::string>{bin + "/stepchoir", "tone", "--port", vb.pty(), "--motor", std::to_string(m), "--hz",
                                 std::to_string(hz[m])},
        false));
    std::this_thread::sleep_for(std::chrono::milliseconds(Board::kBootWaitMs + 300));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (auto &host : hosts) kill(host->pid(), SIGKILL);
  for (auto &host : hosts) host->wait();
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  REQUIRE(!t.frame_ends.empty());
  const uint64_t last_frame = t.frame_ends.back();
  const double watchdog_s = kDefaultWatchdogMs / 1000.0;
  for (int m = 0; m < 5; ++m) {
    INFO("motor " << m);
    REQUIRE(t.motor[m].steps.size() > 20);  // it was playing
    const uint64_t last_step = t.motor[m].steps.back().rise_cycle;
    const double after_s = (double(last_step) - double(last_frame)) / t.f_cpu_hz;
    INFO("last step " << after_s * 1000 << " ms after the last frame");
    CHECK(after_s > watchdog_s - 1.0 / hz[m] - 0.002);  // it played on until the watchdog
    CHECK(after_s <= watchdog_s + 1.0 / hz[m]);          // and stopped then
    std::printf("sigkill mega motor %d: last step %.1f ms after the last frame\n", m, after_s * 1000);
  }
  // The shared enables go off (high: RAMPS enables are active low) once the watchdog fires.
  bool disabled = false;
  for (int m = 0; m < 5; ++m)
    for (const auto &e : t.motor[m].enables)
      disabled = disabled || (e.cycle > last_frame && e.value == 1 &&
                              (double(e.cycle) - double(last_frame)) / t.f_cpu_hz <= watchdog_s + 0.001);
  CHECK(disabled);
}

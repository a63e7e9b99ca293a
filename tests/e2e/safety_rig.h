// safety_rig.h: what the safety e2e files share (test_safety.cpp: the rail; test_safety_link.cpp:
// the link and the stops): a traced virtual board with a host session, the firmware's timing
// tolerances, and the checks several cases run with different figures.
#ifndef STEPCHOIR_TESTS_E2E_SAFETY_RIG_H
#define STEPCHOIR_TESTS_E2E_SAFETY_RIG_H

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

namespace safety_rig {

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
inline std::string press_reversal_sequence(const tr::MotorTrace &m, const std::vector<size_t> &reversals) {
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
inline double worst_interval_deviation(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
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
inline double worst_mean_interval_change(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
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
inline double worst_interval_deviation_anywhere(const std::vector<tr::Step> &steps, double period_cycles) {
  double worst = 0;
  for (size_t k = 1; k < steps.size(); ++k)
    worst = std::max(worst, std::abs(double(steps[k].rise_cycle - steps[k - 1].rise_cycle) - period_cycles) /
                                period_cycles);
  return worst;
}

// Reversals whose turning step (the step before the reversal) is not within `slack` steps of
// either end of a rail of `rail` steps.
inline size_t reversals_away_from_ends(const std::vector<tr::Step> &steps, const std::vector<size_t> &reversals,
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
inline void check_bounce_back(const std::string &board, uint32_t chatter_us) {
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
inline void check_watchdog(uint16_t timeout_ms) {
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
inline void check_busy(double hz) {
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

}  // namespace safety_rig

#endif  // STEPCHOIR_TESTS_E2E_SAFETY_RIG_H

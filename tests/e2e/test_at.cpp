// test_at.cpp: the firmware's timed `at` entries, the player's building blocks, sent straight to
// the virtual board: a change and a silence fall on their board ticks, on a sounding motor and
// under a load of four motors near the top of the range; a late entry is answered `late`.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "board/board.h"
#include "core/pitch.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using e2e::scratch;

TEST_CASE("at: a sounding motor is struck again exactly on the time, and a timed silence falls on its time",
          "[play][at]") {
  // The player's building blocks on the firmware: motor 0 sounds, an `at` entry changes its
  // note (a legato step of a melody), another silences it; motor 1 starts on a silent motor
  // and fixes board ticks to trace cycles.
  const std::string trace_path = scratch("at-strike.csv");
  VboardProcess vb({"--board", "uno", "--no-pacing", "--seconds", "60", "--trace", trace_path, "--quiet"});
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  const double f = caps.f_cpu_hz;
  b.send(e2e::watchdog_payload(0));
  const uint32_t p_old = hz_to_period_q8(880.0, f), p_new = hz_to_period_q8(784.0, f);
  for (int round = 0; round < 12; ++round) {
    // Each round another phase of the old note's steps against the strike time.
    const uint32_t t0 = e2e::start_note_at(b, 1, hz_to_period_q8(440.0, f), caps.f_cpu_hz, 0.05);
    b.send(e2e::at_payload(t0, {{0, p_old}}));
    const uint32_t strike = t0 + static_cast<uint32_t>(0.1 * f) + static_cast<uint32_t>(round * 1379);
    const uint32_t stop = strike + static_cast<uint32_t>(0.1 * f) + static_cast<uint32_t>(round * 977);
    b.send(e2e::at_payload(strike, {{0, p_new}}));
    b.send(e2e::at_payload(stop, {{0, sc::kPeriodSilent}, {1, sc::kPeriodSilent}}));
    e2e::wait_board_time(b, stop + static_cast<uint32_t>(0.02 * f));
  }
  // An entry whose time has passed plays at once and is answered with error `late`, naming
  // the motor, so that a host learns its lead was too short.
  b.send(e2e::at_payload(e2e::board_ticks(b) - static_cast<uint32_t>(0.01 * f), {{2, p_new}}));
  const auto late = b.wait_reply(sc::kMsgError, 2000);
  REQUIRE(late);
  CHECK((*late)[1] == sc::kErrLate);
  CHECK((*late)[2] == sc::kMsgAt);
  CHECK((*late)[3] == 2);
  b.send(periods_payload({{2, sc::kPeriodSilent}}));
  vb.stop();
  const auto t = sc::trace::read_trace(trace_path);
  // Motor 1's notes start exactly on their times: they give the offset of each round.
  const auto &m0 = t.motor.at(0).steps, &m1 = t.motor.at(1).steps;
  std::vector<uint64_t> round_start;
  for (size_t i = 0; i < m1.size(); ++i)
    if (i == 0 || m1[i].rise_cycle - m1[i - 1].rise_cycle > 0.01 * f) round_start.push_back(m1[i].rise_cycle);
  REQUIRE(round_start.size() == 12);
  for (int round = 0; round < 12; ++round) {
    INFO("round " << round);
    const uint64_t t0 = round_start[static_cast<size_t>(round)];
    const uint64_t strike = t0 + static_cast<uint64_t>(0.1 * f) + static_cast<uint64_t>(round * 1379);
    const uint64_t stop = strike + static_cast<uint64_t>(0.1 * f) + static_cast<uint64_t>(round * 977);
    std::vector<uint64_t> edges;
    // (from 10 us before t0: due on the same tick, motor 0's edge may rise just before motor 1's)
    for (const auto &s : m0)
      if (s.rise_cycle + static_cast<uint64_t>(10e-6 * f) >= t0 && s.rise_cycle < stop + static_cast<uint64_t>(0.02 * f))
        edges.push_back(s.rise_cycle);
    REQUIRE(!edges.empty());
    CHECK(std::fabs(static_cast<double>(edges.front()) - static_cast<double>(t0)) <= 10e-6 * f);
    // Every edge on its grid (within 10 us: two motors' edges may meet): the old one from t0
    // up to the strike, the new one from it on; none after the silence's time.
    const double po = p_old / 256.0, pn = p_new / 256.0, tol = 10e-6 * f;
    size_t k_old = 0, k_new = 0;
    if (std::getenv("STEPCHOIR_TEST_NOTES"))
      for (uint64_t e : edges)
        if (e + 60000 > strike && e < strike + 60000) std::printf("round %d edge %+lld\n", round, static_cast<long long>(e - strike));
    for (uint64_t e : edges) {
      if (static_cast<double>(e) < static_cast<double>(strike) - tol) {
        CHECK(std::fabs(static_cast<double>(e) - (t0 + po * static_cast<double>(k_old++))) <= tol);
      } else {
        CHECK(std::fabs(static_cast<double>(e) - (strike + pn * static_cast<double>(k_new++))) <= tol);
        CHECK(e < stop);
      }
    }
    // Every grid point before the silence got its edge: the note lasts to its time. The old
    // note's edges all sound up to 512 ticks before the strike (one closer would be a double
    // step: the strike takes its place).
    CHECK(k_new == static_cast<size_t>(std::ceil((stop - strike) / pn)));
    CHECK(k_old == static_cast<size_t>(std::ceil((strike - 512.0 - t0) / po)));
  }
}

TEST_CASE("at: entries keep their time while four motors sound near the top of the range", "[play][at]") {
  // Four motors at MIDI 101-104 (12,200 steps a second) ask more steps of the Uno than its
  // step ISRs can make on time. One motor changes note every 2.5 ms, 160 times. The main loop
  // takes each entry from the queue kTakeTicks (3 ms) before its time and hands it to the
  // motor's channel, so almost none comes late (the board answers those `late`); each change
  // sounds at its pitch until the next, and strikes within the overload's lateness.
  // The board runs at a quarter of real time, paced by the wall clock from one clock sample as
  // a player sends: the host's lead never runs short. (At MIDI 105-108 with this traffic the
  // main loop gets too little to keep up with the line: frames are lost; see RELIABILITY.md.)
  const std::string trace_path = scratch("at-busy.csv");
  VboardProcess vb({"--board", "uno", "--speed", "0.25", "--seconds", "60", "--trace", trace_path, "--quiet",
                    "--no-measure"});
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  const double f = caps.f_cpu_hz;
  b.send(e2e::watchdog_payload(0));
  b.send({sc::kMsgResetCounters});
  uint32_t high[4], low[4];  // MIDI 104-101, and four semitones lower
  for (int m = 0; m < 4; ++m) {
    high[m] = hz_to_period_q8(note_hz(104 - m), f);
    low[m] = hz_to_period_q8(note_hz(100 - m), f);
  }
  const auto wall0 = std::chrono::steady_clock::now();
  const uint32_t board0 = e2e::board_ticks(b);
  const auto board_now = [&] {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return board0 + static_cast<uint32_t>(s * 0.25 * f);
  };
  const uint32_t t0 = board0 + e2e::ticks_for(0.05, caps.f_cpu_hz);
  b.send(e2e::at_payload(t0, {{0, high[0]}, {1, high[1]}, {2, high[2]}, {3, high[3]}}));
  struct Change {
    uint32_t at;
    uint8_t motor;
    uint32_t period;
  };
  std::vector<Change> changes;
  for (int k = 0; k < 160; ++k) {
    const auto m = static_cast<uint8_t>(k % 4);
    changes.push_back({t0 + e2e::ticks_for(0.02 + 0.0025 * k, caps.f_cpu_hz), m, (k / 4) % 2 ? high[m] : low[m]});
  }
  const size_t in_queue = 16;  // of the board's 24: 40 ms of board time ahead
  for (size_t k = 0; k < changes.size(); ++k) {
    while (k >= in_queue && static_cast<int32_t>(board_now() - changes[k - in_queue].at) < 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    b.send(e2e::at_payload(changes[k].at, {{changes[k].motor, changes[k].period}}));
  }
  const uint32_t end = changes.back().at + e2e::ticks_for(0.01, caps.f_cpu_hz);
  b.send(e2e::at_payload(end, {{0, sc::kPeriodSilent}, {1, sc::kPeriodSilent}, {2, sc::kPeriodSilent},
                               {3, sc::kPeriodSilent}}));
  e2e::wait_board_time(b, end + e2e::ticks_for(0.01, caps.f_cpu_hz));
  const auto st = b.status();
  REQUIRE(st);
  INFO("the board's last error: " << sc::error_name(st->head.last_error));
  // None refused; at most two of the 164 entries made late (answered `late`: while the ISR is
  // this far behind, an entry may find edges due all the time).
  CHECK((st->head.last_error == sc::kErrNone || st->head.last_error == sc::kErrLate));
  for (const auto &e : b.errors()) CHECK(e.code == sc::kErrLate);
  CHECK(b.errors().size() <= 2);
  vb.stop();
  const auto t = sc::trace::read_trace(trace_path);
  const int64_t offset = e2e::cycle_offset(t.motor.at(0), t0);
  std::vector<double> strike_us;
  double steps_played = 0, steps_on_grid = 0;
  for (size_t k = 0; k + 4 < changes.size(); ++k) {
    const Change &c = changes[k];
    INFO("change at " << (c.at - t0) / f * 1e3 << " ms on motor " << int{c.motor});
    const auto &steps = t.motor.at(c.motor).steps;
    const double from = static_cast<double>(c.at) + static_cast<double>(offset);
    const double to = static_cast<double>(changes[k + 4].at) + static_cast<double>(offset);  // its next change
    std::vector<double> edges;
    for (const auto &st_edge : steps)
      if (static_cast<double>(st_edge.rise_cycle) >= from - 10e-6 * f && static_cast<double>(st_edge.rise_cycle) < to)
        edges.push_back(static_cast<double>(st_edge.rise_cycle));
    REQUIRE(edges.size() >= 20);
    strike_us.push_back((edges.front() - from) / f * 1e6);
    // The new note from its strike to the next change: as many steps as its grid has, give or
    // take the edges at either end (each up to a few hundred us late, then caught up); a
    // change not made would leave the old note, four semitones off: ten steps or more.
    const double grid = (to - from) / (c.period / 256.0);
    CHECK(std::fabs(static_cast<double>(edges.size()) - grid) <= 4.0);
    steps_played += static_cast<double>(edges.size());
    steps_on_grid += grid;
  }
  std::sort(strike_us.begin(), strike_us.end(), [](double x, double y) { return std::fabs(x) < std::fabs(y); });
  const double p50 = strike_us[strike_us.size() / 2], p99 = strike_us[strike_us.size() * 99 / 100];
  std::printf("at under load: strikes p50 %.1f us, p99 %.1f us, max %.1f us from their ticks; %zu late replies; "
              "%u late edges; %.0f steps for %.1f on the grid\n",
              p50, p99, strike_us.back(), b.errors().size(), unsigned{st->head.late_edges}, steps_played, steps_on_grid);
  CHECK(std::fabs(strike_us[strike_us.size() * 99 / 100]) < 450.0);
}

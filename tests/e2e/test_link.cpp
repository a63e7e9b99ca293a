// test_link.cpp: the link budget. A host that keeps what it sends under
// sc::kLinkBudgetBytesPerSecond loses no frame, even with every motor playing fast, and the
// motors stay in tune meanwhile (real firmware on the virtual board).
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <utility>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "core/pitch.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

// Plays a chord on every motor, then for `seconds` of board time sends each motor's period
// again and a heartbeat, round after round, at `bytes_per_second`; checks that the board
// decoded every frame and that every motor kept its pitch and timing. The board runs in real
// time, as a real one does: a simulation running several times as fast as real time would
// pass more board time in each of the host's round trips than the burst the budget allows.
void check_budget(const std::string &board, double bytes_per_second, double seconds) {
  const std::string trace_path = e2e::scratch("link-budget-" + board + ".csv");
  e2e::StoppableVboard vb({"--board", board, "--seconds", "60", "--trace", trace_path, "--quiet"});
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  b.send(e2e::watchdog_payload(0));  // a pause of the host must not silence the board
  // High notes, about 5,800 steps a second in all on five motors (5,000 on four).
  const int notes[] = {88, 90, 86, 83, 81};
  std::vector<sc::PeriodEntry> chord;
  std::vector<std::vector<uint8_t>> round;
  for (uint8_t m = 0; m < caps.motor_count; ++m) {
    chord.push_back({m, hz_to_period_q8(note_hz(notes[m]), caps.f_cpu_hz)});
    b.send(config_payload(e2e::motor_config(m, 100000)));
    round.push_back(e2e::tone_payload(m, chord.back().period_q8));
  }
  round.push_back({sc::kMsgHeartbeat});
  size_t round_bytes = 0;
  for (const auto &p : round) round_bytes += frame(p).size();
  b.send(periods_payload(chord));
  b.send({sc::kMsgResetCounters});
  const uint32_t from = e2e::board_ticks(b, 0x31) + e2e::ticks_for(0.05, caps.f_cpu_hz);

  // Paced by the board's own clock (a clock request a round), so that a slow or busy host
  // machine cannot bunch the bytes up.
  // A token bucket: credit grows at bytes_per_second of board time, up to the burst the budget
  // allows, and each round spends its bytes. A host round trip that spans more board time than
  // the burst (the machine stalled the host or the simulation) loses credit, so the test sends
  // until `seconds` of the budget are out, within a board-time cap, and asks that one second of
  // board time carried the whole budget.
  const double burst_bytes = sc::kLinkBurstBytes;
  const double target_bytes = bytes_per_second * seconds;
  size_t frames = 0, bytes = 0, clock_requests = 0;
  double credit = 0;
  uint32_t last = from;
  const uint32_t second = e2e::ticks_for(1.0, caps.f_cpu_hz);
  const uint32_t until = from + e2e::ticks_for(3 * seconds, caps.f_cpu_hz);
  std::vector<std::pair<uint32_t, size_t>> sent_at;  // (board ticks, bytes sent up to then)
  size_t window_start = 0, best_second_bytes = 0;
  for (uint8_t seq = 0x40; bytes < target_bytes; ++seq) {
    const uint32_t now = e2e::board_ticks(b, seq);
    ++clock_requests;
    if (static_cast<int32_t>(now - until) >= 0) break;
    if (static_cast<int32_t>(now - last) > 0) {
      credit = std::min(burst_bytes, credit + (now - last) / double(caps.f_cpu_hz) * bytes_per_second);
      last = now;
    }
    while (credit >= round_bytes) {
      e2e::send_back_to_back(b, round);
      frames += round.size();
      bytes += round_bytes;
      credit -= round_bytes;
    }
    sent_at.push_back({now, bytes});
    // the bytes sent in the board second that ends now: after the last round a second before
    while (window_start + 1 < sent_at.size() && now - sent_at[window_start + 1].first > second) ++window_start;
    if (now - sent_at[window_start].first > second)
      best_second_bytes = std::max(best_second_bytes, bytes - sent_at[window_start].second);
  }
  const uint32_t to = e2e::board_ticks(b, 0x32);
  const auto st = b.status(2000);
  REQUIRE(st);
  b.send({sc::kMsgStopAll});
  REQUIRE(vb.stop() == 0);
  std::printf("link budget %s: %.0f bytes/s, %zu frames sent (%zu bytes) in %.2f s, best second %zu bytes, "
              "frames ok %u bad %u, uart overruns %u, late edges %u\n",
              board.c_str(), bytes_per_second, frames, bytes, (to - from) / double(caps.f_cpu_hz), best_second_bytes,
              st->head.frames_ok, st->head.frames_bad, st->head.uart_overruns, st->head.late_edges);
  // the budget was used, not just allowed (clock round trips leave a little of it unused)
  CHECK(bytes >= target_bytes);
  CHECK(best_second_bytes >= 0.9 * bytes_per_second);
  CHECK(st->head.frames_bad == 0);
  CHECK(st->head.uart_overruns == 0);
  // every frame sent after the counters were reset, the clock requests and the status request
  CHECK(st->head.frames_ok == frames + clock_requests + 3);

  const tr::Trace t = tr::read_trace(trace_path);
  for (uint8_t m = 0; m < caps.motor_count; ++m) {
    const auto edges = tr::rise_cycles_in_window(t.motor[m].steps, from, to);
    INFO(board << " motor " << int(m) << ": " << edges.size() << " edges");
    REQUIRE(edges.size() > 1000);
    const tr::PitchFit f = tr::fit_edges(edges, chord[m].period_q8 / 256.0, t.f_cpu_hz);
    INFO("cents " << f.cents_error << " p99 " << f.residual_p99_us << " us, max " << f.residual_max_us << " us");
    CHECK(std::abs(f.cents_error) < 0.05);
    CHECK(f.residual_p99_us < 25.0);  // the envelope with live traffic (test_pitch.cpp)
  }
}

}  // namespace

TEST_CASE("link: mega decodes every frame at the link budget while five motors play fast", "[pacing]") {
  const char *rate = std::getenv("STEPCHOIR_LINK_RATE");  // for measuring other rates by hand
  check_budget("mega", rate ? std::atof(rate) : sc::kLinkBudgetBytesPerSecond, 3.0);
}

TEST_CASE("link: uno decodes every frame at the link budget while four motors play fast", "[pacing]") {
  const char *rate = std::getenv("STEPCHOIR_LINK_RATE");
  check_budget("uno", rate ? std::atof(rate) : sc::kLinkBudgetBytesPerSecond, 3.0);
}

namespace {

// Firmware latency: from the last byte of a set-period frame reaching the board's UART to the
// motor's first STEP edge, over `notes` notes on a silent motor (cycles of the virtual board's
// trace, exact). Returns the latencies in CPU cycles.
// Times `notes` onsets on motor 0 (its STEP pulse and DIR set-up pulse_us), and checks every
// step's DIR set-up from the trace. behind_refresh: each note's frame goes right behind a
// silence for every motor in one frame, as the live host's refresh (BoardLink, kRefreshMs)
// sends them, in the same write.
std::vector<double> onset_latencies(const std::string &board, int notes, uint8_t pulse_us = 2,
                                    bool behind_refresh = false) {
  const std::string trace_path = e2e::scratch("link-onset-" + board + ".csv");
  e2e::StoppableVboard vb({"--board", board, "--no-pacing", "--seconds", "120", "--trace", trace_path,
                           "--trace-frames", "--quiet"});
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  b.send(e2e::watchdog_payload(0));
  sc::ConfigBody config = e2e::motor_config(0, 100000);
  config.pulse_us = pulse_us;
  if (pulse_us >= 5) config.driver = sc::kDriverTb6600;
  b.send(config_payload(config));
  // Notes are timed on a board that has done with the frames before them: sent right behind
  // the configuration frame, the first note's frame waited about 290 us for its handling (the
  // one p99 outlier of 100 notes before this wait).
  e2e::wait_board_time(b, e2e::board_ticks(b, 0x1f) + e2e::ticks_for(0.002, caps.f_cpu_hz));
  const uint32_t period = hz_to_period_q8(note_hz(69), caps.f_cpu_hz);
  for (int i = 0; i < notes; ++i) {
    // 10 ms of A4 (2.3 ms a step) and 5 ms of silence, both timed from a clock request sent
    // after their frame (for a note, only once the simulation, unpaced, has run well past its
    // first step); each note at another phase of the board's step timer and main loop.
    if (behind_refresh) {
      std::vector<uint8_t> refresh(caps.motor_count * sc::kSetPeriodBytes);
      for (uint8_t m = 0; m < caps.motor_count; ++m) sc::put_entry(&refresh[m * sc::kSetPeriodBytes], m, 0);
      b.send(refresh);
    }
    b.send(e2e::tone_payload(0, period));
    std::this_thread::sleep_for(std::chrono::milliseconds(3));  // no other frame before its first step
    e2e::wait_board_time(b, e2e::board_ticks(b, 0x20) + e2e::ticks_for(0.010 + 0.000137 * (i % 7), caps.f_cpu_hz));
    b.send(e2e::tone_payload(0, 0));
    e2e::wait_board_time(b, e2e::board_ticks(b, 0x21) + e2e::ticks_for(0.005, caps.f_cpu_hz));
  }
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  // Pair each note's first step with the last frame that reached the board before it: the
  // note's own frame.
  std::vector<double> out;
  const auto &steps = t.motor[0].steps;
  size_t s = 0;
  uint64_t prev_step = 0;
  for (size_t i = 0; i < steps.size(); ++i) {
    // a note's first step: the first after a silence longer than a step (4 ms)
    if (i > 0 && steps[i].rise_cycle - prev_step < e2e::ticks_for(0.004, caps.f_cpu_hz)) {
      prev_step = steps[i].rise_cycle;
      continue;
    }
    prev_step = steps[i].rise_cycle;
    while (s + 1 < t.frame_ends.size() && t.frame_ends[s + 1] < steps[i].rise_cycle) ++s;
    REQUIRE(t.frame_ends[s] < steps[i].rise_cycle);
    out.push_back(double(steps[i].rise_cycle - t.frame_ends[s]));
  }
  // DIR set-up: every step comes at least a pulse width (the configured pulse) after the
  // motor's last DIR change, also the first step of a note that turned it (its channel armed
  // by the main loop right after DIR, sched::command). The border rule turns this carriage,
  // near mid travel, at most notes: the check sees those.
  const double setup_cycles = pulse_us * 1e-6 * caps.f_cpu_hz;
  size_t turned_onsets = 0;
  double least_setup = 1e18;
  for (const auto &st : steps) {
    const auto &dirs = t.motor[0].dir_changes;
    auto after = std::upper_bound(dirs.begin(), dirs.end(), st.rise_cycle,
                                  [](uint64_t c, const tr::LevelChange &d) { return c < d.cycle; });
    if (after == dirs.begin()) continue;
    const double setup = double(st.rise_cycle - std::prev(after)->cycle);
    if (setup < 0.001 * caps.f_cpu_hz) ++turned_onsets;  // DIR turned within 1 ms before it
    least_setup = std::min(least_setup, setup);
    INFO("step at cycle " << st.rise_cycle << ": DIR changed " << setup << " cycles before");
    REQUIRE(setup >= setup_cycles);
    REQUIRE(st.width_cycles >= setup_cycles);  // the STEP pulse too
  }
  std::printf("onset %s: %zu steps came within 1 ms of a DIR change, the soonest %.2f us after it\n", board.c_str(),
              turned_onsets, least_setup * 1e6 / caps.f_cpu_hz);
  CHECK(turned_onsets >= static_cast<size_t>(notes / 10));
  return out;
}

}  // namespace

// Measured from the cycle at which the virtual board hands the frame's delimiter to simavr's
// UART: the byte is received one byte time (10 us) later, as on the wire, where it is also the
// last 10 us of the frame's wire time. The firmware then decodes it (the main loop waits for a
// frame's bytes as they come), checks the entry and, the motor being silent, sets DIR and
// writes the motor's channel compare kTriggerLeadTicks (3 us) ahead (sched::command, fire); the
// channel's stub raises the edge. The first note of a run wakes the drivers; it is reported
// apart. The spread is the main loop's phase when the frame comes (a pass's other work).
// The test holds every note within 0.3 ms (a MIDI cable takes 960 us for one note-on); its p99
// guard is a regression guard above the measured spread (bench/results/onset-latency.md).
TEST_CASE("link: a note starts within 0.3 ms of its frame's last byte (uno and mega)") {
  for (const std::string board : {"uno", "mega"}) {
    const char *notes_env = std::getenv("STEPCHOIR_ONSET_NOTES");  // more notes, by hand
    const int notes = notes_env ? std::atoi(notes_env) : 100;
    std::vector<double> lat = onset_latencies(board, notes);
    INFO(board << ": " << lat.size() << " notes");
    REQUIRE(lat.size() == static_cast<size_t>(notes));
    const double us = 1e6 / 16e6;
    const double first = lat.front() * us;
    lat.erase(lat.begin());
    std::sort(lat.begin(), lat.end());
    const double p99 = lat[lat.size() * 99 / 100] * us;
    std::printf("onset %s: frame's last byte handed to the UART -> first STEP, %zu notes after the first: min %.1f us, "
                "p50 %.1f us, p99 %.1f us, max %.1f us (from its receive, 10 us later: p99 %.1f us); first note "
                "(drivers waking) %.1f us\n",
                board.c_str(), lat.size(), lat.front() * us, lat[lat.size() / 2] * us, p99, lat.back() * us,
                p99 - 10.0, first);
    // Of 99 notes the p99 is their largest: a frame whose last byte meets the main loop's other
    // work (the queue and driver checks, a reply) waits for it; the target is the 300 us below.
    CHECK(p99 < 150.0);
    CHECK(lat.back() * us < 300.0);
    CHECK(first < 300.0);
  }
}

// A TB6600 wants 5 us between a DIR change and the next STEP edge: a note that turns the motor
// waits for it before its first edge (the compare is written a pulse width ahead, 5 us, after
// DIR), and its STEP pulses last 5 us. (DIR comes about 16 us before the raise whatever the
// pulse: the check holds the property, not the wait.)
TEST_CASE("link: a TB6600's note that turns its motor steps 5 us after DIR (uno)") {
  std::vector<double> lat = onset_latencies("uno", 30, 5);
  REQUIRE(lat.size() == 30u);
  std::sort(lat.begin(), lat.end());
  std::printf("onset uno, TB6600 (5 us): p50 %.1f us, max %.1f us\n", lat[lat.size() / 2] / 16.0, lat.back() / 16.0);
  CHECK(lat.back() / 16.0 < 300.0);
}

// The live host sends every motor's state again every kRefreshMs (BoardLink's refresh: one
// frame, four or five entries); a note whose frame comes right behind it waits for that frame's
// bytes and handling. Silence for a silent motor is the refresh's common entry and costs the
// firmware about 30 cycles (sched::set_period); the bound is a regression guard above the
// measured spread (bench/results/onset-latency.md).
TEST_CASE("link: a note right behind the host's refresh of every motor starts within 0.2 ms (uno)") {
  std::vector<double> lat = onset_latencies("uno", 30, 2, true);
  REQUIRE(lat.size() == 30u);
  lat.erase(lat.begin());  // the drivers' wake
  std::sort(lat.begin(), lat.end());
  std::printf("onset uno, right behind a refresh frame: p50 %.1f us, max %.1f us\n", lat[lat.size() / 2] / 16.0,
              lat.back() / 16.0);
  CHECK(lat.back() / 16.0 < 200.0);  // above the measured spread, below the figure without the early return
}

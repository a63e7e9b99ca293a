// test_pitch.cpp: the real firmware on the virtual board plays every motor in tune, on
// time to the cycle, with frames arriving at full speed meanwhile (uno and mega).
#include <catch2/catch.hpp>

#include <cstdio>

#include "analysis.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

// Chords (MIDI notes), one column per motor: every motor plays low, middle and high notes,
// together covering MIDI 24-108 (32.7 Hz to 4186 Hz).
const int kChords[4][5] = {
    {24, 50, 77, 108, 45},
    {30, 57, 84, 101, 62},
    {36, 64, 91, 96, 73},
    {43, 70, 88, 105, 99},
};
const double kChordSeconds = 1.0;
const double kSettleSeconds = 0.05;  // skip the first edges of each chord window

// Plays the chords on `board_name`, flooding frames, and returns the trace.
tr::Trace play_chords(const std::string &board_name, std::vector<std::vector<uint32_t>> *periods, int pause_us) {
  const std::string trace_path = e2e::scratch("pitch-" + board_name + ".csv");
  // The host says hello whenever the machine lets it (unpaced, the board runs two to three
  // times as fast as real time meanwhile); the chords start 0.2 s after it, and the flood
  // stops once the board's clock is past the last chord: the board's time cap is only a bound.
  const double seconds = 60;
  std::vector<std::string> args{"--board", board_name, "--seconds", std::to_string(seconds), "--trace", trace_path,
                                "--quiet"};
  if (pause_us == 0) args.push_back("--no-pacing");  // the flood keeps up with any speed
  VboardProcess vb(args);
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  const uint32_t t0 = e2e::board_ticks(b) + uint32_t(0.2 * caps.f_cpu_hz);
  const double t0_s = static_cast<double>(t0) / caps.f_cpu_hz;
  INFO("the host said hello " << t0_s - 0.2 << " s into the board's " << seconds << " s");
  REQUIRE(t0_s + 4 * kChordSeconds < seconds);
  for (int c = 0; c < 4; ++c) {
    std::vector<sc::PeriodEntry> entries;
    std::vector<uint32_t> ps;
    for (uint8_t m = 0; m < caps.motor_count; ++m) {
      const uint32_t p = hz_to_period_q8(note_hz(kChords[c][m]), caps.f_cpu_hz);
      entries.push_back({m, p});
      ps.push_back(p);
    }
    periods->push_back(ps);
    b.send(e2e::at_payload(t0 + uint32_t(c * kChordSeconds * caps.f_cpu_hz), entries));
  }
  // Every chord queued before the flood: a receive ring that laps under the flood would take
  // the `at` frames' bytes with it.
  const std::optional<Status> queued = b.status(1000);
  REQUIRE(queued);
  REQUIRE(queued->head.queue_used == 4 * caps.motor_count);
  std::optional<Status> status;
  const uint32_t end = t0 + uint32_t((4 * kChordSeconds + 0.1) * caps.f_cpu_hz);
  int late = 0;
  const size_t frames = e2e::flood_until_exit(b, vb, nullptr, &status, pause_us, end, &late);
  INFO("frames sent " << frames);
  REQUIRE(status);
  CHECK(late == 0);  // every chord's entries taken in time, however busy the main loop
  std::printf("%s: frames ok %u bad %u, uart overruns %u, late edges %u, last error %u\n", board_name.c_str(),
              status->head.frames_ok, status->head.frames_bad, status->head.uart_overruns, status->head.late_edges,
              status->head.last_error);
  CHECK(frames > 100);
  REQUIRE(vb.stop() == 0);
  tr::Trace t = tr::read_trace(trace_path);
  // board ticks start about 1 ms after the trace's cycle 0: the windows below allow for it
  t.summary_lines.push_back("t0=" + std::to_string(t0));
  return t;
}

// Timing bounds for edges against their ideal grid (one constant offset removed per note).
struct Bounds {
  double p99_us, max_us;  // a note's edges (p99: notes of tr::kMinEdgesForP99 edges or more)
  double motor_p99_us;    // all of a motor's edges on its commanded grids, one offset removed (the measure)
};

// A p99 is checked per note where the note has tr::kMinEdgesForP99 edges or more (of fewer it
// is their largest, which the max bound checks; one offset per note removed), and over every
// motor's edges together, against the grids it was commanded with one constant offset per
// motor removed (the issue's "each edge within 2 us of its ideal time after removing one
// constant offset per motor").
// The targets (the bounds each test checks are below, with why).
const double kTargetP99Us = 2.0, kTargetMaxUs = 8.0;

// Checks pitch and timing of every motor in every chord window.
void check_chords(const std::string &board_name, int pause_us, Bounds bounds) {
  std::vector<std::vector<uint32_t>> periods;
  const tr::Trace t = play_chords(board_name, &periods, pause_us);
  const uint64_t t0 = std::stoull(t.summary_lines.back().substr(3));
  double worst_cents = 0, worst_p99_us = 0, worst_max_us = 0, worst_motor_p99_us = 0;
  // A motor's edges against the grids it was commanded (each chord's first edge due on the
  // chord's time), with one constant offset removed: the measure. Board ticks to trace
  // cycles: motor 0's first edge of chord 0 (the motors are silent before it).
  const auto first = tr::rise_cycles_in_window(t.motor[0].steps, t0, t0 + uint64_t(kChordSeconds * t.f_cpu_hz));
  REQUIRE(!first.empty());
  const uint64_t tick0_cycle = first.front() - t0;
  std::vector<std::vector<double>> motor_residuals(t.motor.size());  // cycles, signed
  for (size_t c = 0; c < periods.size(); ++c) {
    for (size_t m = 0; m < periods[c].size(); ++m) {
      const uint64_t from = t0 + uint64_t((c * kChordSeconds + kSettleSeconds) * t.f_cpu_hz);
      const uint64_t to = t0 + uint64_t((c + 1) * kChordSeconds * t.f_cpu_hz);
      const auto edges = tr::rise_cycles_in_window(t.motor[m].steps, from, to);
      INFO(board_name << " chord " << c << " motor " << m << " MIDI " << kChords[c][m] << ": " << edges.size()
                      << " edges");
      REQUIRE(edges.size() >= 25);
      const tr::PitchFit f = tr::fit_edges(edges, periods[c][m] / 256.0, t.f_cpu_hz);
      INFO("cents " << f.cents_error << " p99 " << f.residual_p99_us << " us, max " << f.residual_max_us << " us");
      CHECK(std::abs(f.cents_error) < 0.05);
      if (edges.size() >= tr::kMinEdgesForP99) CHECK(f.residual_p99_us < bounds.p99_us);
      CHECK(f.residual_max_us < bounds.max_us);
      if (f.residual_max_us >= kTargetMaxUs || (edges.size() >= tr::kMinEdgesForP99 && f.residual_p99_us >= kTargetP99Us))
        std::printf("%s chord %zu motor %zu MIDI %d (%zu edges): p99 %.3f us, max %.3f us, over the target\n",
                    board_name.c_str(), c, m, kChords[c][m], edges.size(), f.residual_p99_us, f.residual_max_us);
      const uint64_t due = t0 + uint32_t(c * kChordSeconds * t.f_cpu_hz) + tick0_cycle;  // as play_chords
      for (double r : tr::commanded_grid_residuals_cycles(edges, due, periods[c][m])) motor_residuals[m].push_back(r);
      worst_cents = std::max(worst_cents, std::abs(f.cents_error));
      if (edges.size() >= tr::kMinEdgesForP99) worst_p99_us = std::max(worst_p99_us, f.residual_p99_us);
      worst_max_us = std::max(worst_max_us, f.residual_max_us);
    }
  }
  for (size_t m = 0; m < t.motor.size(); ++m) {
    double mean = 0;
    for (double r : motor_residuals[m]) mean += r / double(motor_residuals[m].size());
    std::vector<double> off_us;
    for (double r : motor_residuals[m]) off_us.push_back(std::abs(r - mean) * 1e6 / t.f_cpu_hz);
    const double p99 = tr::percentile_nearest_rank(off_us, tr::kP99Quantile);
    INFO(board_name << " motor " << m << ": " << off_us.size() << " edges, offset " << mean << " cycles, p99 " << p99
                    << " us");
    CHECK(p99 < bounds.motor_p99_us);
    worst_motor_p99_us = std::max(worst_motor_p99_us, p99);
    const auto w = tr::min_pulse_width_cycles(t.motor[m].steps);
    REQUIRE(w);
    CHECK(*w >= 2 * t.f_cpu_hz / 1e6);
  }
  std::printf("%s: worst |cents| %.5f, worst motor p99 %.3f us, worst note p99 (%zu+ edges) %.3f us, worst max %.3f us\n",
              board_name.c_str(), worst_cents, worst_motor_p99_us, tr::kMinEdgesForP99, worst_p99_us, worst_max_us);
}

}  // namespace

// The targets (p99 2 us, max 8 us) hold for a motor playing alone (below), and for every motor
// of four or five playing at once (one timer compare channel each): a motor's p99 on the grids
// it was commanded, one offset per motor removed. A single note's p99 (of its 100-4,000 edges:
// the second to fortieth largest) on the Uno at full line speed can exceed 2 us; each run
// prints the notes over the target, and their bound is a regression guard with a margin.
// Figures: bench/results/pitch-uno.md, pitch-mega.md.
const Bounds kFullSpeed = {3.5, kTargetMaxUs, kTargetP99Us};
const Bounds kLiveTraffic = {2.5, kTargetMaxUs, kTargetP99Us};
const Bounds kTarget = {kTargetP99Us, kTargetMaxUs, kTargetP99Us};

TEST_CASE("uno: every motor in tune across MIDI 24-108 - frames at full speed") {
  check_chords("uno", 0, kFullSpeed);
}

TEST_CASE("mega: every motor in tune across MIDI 24-108 - frames at full speed") {
  check_chords("mega", 0, kFullSpeed);
}

TEST_CASE("uno: every motor in tune with a live host's traffic", "[pacing]") { check_chords("uno", 10000, kLiveTraffic); }

TEST_CASE("uno and mega: a motor alone is in tune and on time to 2 us across MIDI 24-108") {
  for (const std::string board : {"uno", "mega"}) {
    const std::string trace_path = e2e::scratch("solo-" + board + ".csv");
    const int notes[] = {24, 36, 48, 60, 72, 84, 96, 108};
    const double note_s = 0.6;
    VboardProcess vb({"--board", board, "--seconds", std::to_string(0.3 + 8 * note_s), "--trace", trace_path,
                      "--quiet"});
    Board b(open_link(vb.pty()));
    const Caps caps = b.hello();
    const uint32_t t0 = e2e::board_ticks(b) + uint32_t(0.2 * caps.f_cpu_hz);
    std::vector<uint32_t> periods;
    for (int i = 0; i < 8; ++i) {
      const uint8_t motor = uint8_t(i % caps.motor_count);
      const uint32_t p = hz_to_period_q8(note_hz(notes[i]), caps.f_cpu_hz);
      periods.push_back(p);
      const uint32_t at = t0 + uint32_t(i * note_s * caps.f_cpu_hz);
      b.send(e2e::at_payload(at, {{motor, p}}));
      b.send(e2e::at_payload(at + uint32_t(note_s * 0.9 * caps.f_cpu_hz), {{motor, sc::kPeriodSilent}}));
    }
    std::optional<Status> status;
    e2e::flood_until_exit(b, vb, nullptr, &status, 10000);
    REQUIRE(vb.wait() == 0);
    const tr::Trace t = tr::read_trace(trace_path);
    std::vector<double> residuals_us;  // every edge of every note, one offset removed per note
    for (int i = 0; i < 8; ++i) {
      const uint64_t from = t0 + uint64_t((i * note_s + kSettleSeconds) * t.f_cpu_hz);
      const uint64_t to = t0 + uint64_t((i + 0.85) * note_s * t.f_cpu_hz);
      const auto edges = tr::rise_cycles_in_window(t.motor[i % caps.motor_count].steps, from, to);
      INFO(board << " MIDI " << notes[i] << ": " << edges.size() << " edges");
      REQUIRE(edges.size() >= 10);
      const tr::PitchFit f = tr::fit_edges(edges, periods[i] / 256.0, t.f_cpu_hz);
      INFO("cents " << f.cents_error << " p99 " << f.residual_p99_us << " us, max " << f.residual_max_us << " us");
      CHECK(std::abs(f.cents_error) < 0.05);
      CHECK(f.residual_max_us < kTarget.max_us);
      for (double r : tr::grid_residuals_cycles(edges, periods[i] / 256.0)) residuals_us.push_back(std::abs(r) * 1e6 / t.f_cpu_hz);
    }
    const double p99_us = tr::percentile_nearest_rank(residuals_us, tr::kP99Quantile);
    std::printf("%s alone: %zu edges, p99 %.3f us\n", board.c_str(), residuals_us.size(), p99_us);
    CHECK(p99_us < kTarget.p99_us);
  }
}

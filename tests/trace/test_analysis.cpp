// test_analysis.cpp: pitch fit, note segmentation, windows and motion checks on synthetic edges.
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>

#include "analysis.h"
#include "synth_trace.h"

using namespace sc::trace;

namespace {

constexpr double kA4PeriodCycles = synth::kFCpuHz / kA4Hz;  // 36363.63... cycles, not an integer
constexpr int kJitterEvery = 50;                            // every 50th edge is disturbed
constexpr int64_t kJitterCycles = 40;                       // by +/- this much

// Edges at round(offset + k * period) with +/-jitter on every kJitterEvery-th edge (alternating
// sign, so the mean offset is unchanged), first and last edge left alone.
std::vector<uint64_t> jittered_edges(size_t count, double period_cycles, double offset_cycles) {
  std::vector<uint64_t> edges;
  int sign = 1;
  for (size_t k = 0; k < count; ++k) {
    int64_t at = std::llround(offset_cycles + double(k) * period_cycles);
    if (k > 0 && k + 1 < count && k % kJitterEvery == 0) {
      at += sign * kJitterCycles;
      sign = -sign;
    }
    edges.push_back(uint64_t(at));
  }
  return edges;
}

// Steps of the given rise cycles, all one direction, positions counting up.
std::vector<Step> steps_at(const std::vector<uint64_t>& cycles) {
  std::vector<Step> steps;
  int64_t position = 0;
  for (uint64_t c : cycles) steps.push_back({c, 1, ++position, synth::kWidthCycles});
  return steps;
}

}  // namespace

TEST_CASE("fit recovers a fractional period to 0.001 cent and the injected jitter", "[analysis]") {
  const size_t kEdges = 4001;
  std::vector<uint64_t> edges = jittered_edges(kEdges, kA4PeriodCycles, 123456.0);
  PitchFit fit = fit_edges(edges, kA4PeriodCycles, synth::kFCpuHz);
  CHECK(fit.edge_count == kEdges);
  CHECK(std::fabs(fit.cents_error) < 0.001);
  CHECK(fit.measured_hz == Approx(kA4Hz).epsilon(1e-7));
  CHECK(fit.ideal_hz == Approx(kA4Hz).epsilon(1e-12));
  CHECK(fit.mean_period_cycles == Approx(kA4PeriodCycles).epsilon(1e-8));
  // rounding to whole cycles adds at most 0.5; the jitter is +/-40 on 2% of the edges
  CHECK(fit.residual_max_cycles >= kJitterCycles - 0.6);
  CHECK(fit.residual_max_cycles <= kJitterCycles + 0.6);
  CHECK(fit.residual_p99_cycles >= kJitterCycles - 0.6);  // 80 of 4001 edges > 1%
  CHECK(fit.residual_p99_cycles <= kJitterCycles + 0.6);
  CHECK(fit.residual_p50_cycles <= 0.6);
  const double cycles_per_us = synth::kFCpuHz / kMicrosPerSecond;
  CHECK(fit.residual_max_us == Approx(fit.residual_max_cycles / cycles_per_us));
  CHECK(fit.residual_p99_us == Approx(fit.residual_p99_cycles / cycles_per_us));
  CHECK(std::fabs(fit.offset_cycles) < 0.6);  // t0 sits on the first edge, give or take rounding
}

TEST_CASE("a p99 below the jitter rate: rare jitter shows in max - not in p99", "[analysis]") {
  std::vector<uint64_t> edges = jittered_edges(20001, kA4PeriodCycles, 0);  // 400 of 20001 jittered = 2%
  for (size_t k = 1; k + 1 < edges.size(); ++k)   // remove all but two of them
    if (k % kJitterEvery == 0 && k != 5000 && k != 5050) edges[k] = uint64_t(std::llround(double(k) * kA4PeriodCycles));
  PitchFit fit = fit_edges(edges, kA4PeriodCycles, synth::kFCpuHz);
  CHECK(fit.residual_p99_cycles <= 0.6);
  CHECK(fit.residual_max_cycles == Approx(double(kJitterCycles)).margin(0.6));
}

TEST_CASE("fit measures a detuned run in cents - sign = sharp positive", "[analysis]") {
  const double kDetuneCents = -10.0;  // flat: a longer period
  const double period = kA4PeriodCycles * std::exp2(-kDetuneCents / kCentsPerOctave);
  std::vector<uint64_t> edges = jittered_edges(2001, period, 1000);
  PitchFit flat = fit_edges(edges, kA4PeriodCycles, synth::kFCpuHz);
  CHECK(flat.cents_error == Approx(kDetuneCents).margin(0.001));
  CHECK(flat.measured_hz < kA4Hz);
  // against its own period the drift vanishes and only the jitter remains
  PitchFit own = fit_edges(edges, period, synth::kFCpuHz);
  CHECK(std::fabs(own.cents_error) < 0.001);
  CHECK(own.residual_max_cycles == Approx(double(kJitterCycles)).margin(0.6));
  // against the wrong period the residuals grow along the run: a linear drift
  CHECK(flat.residual_max_cycles > 1000);
}

TEST_CASE("a step held up at the end of a note does not tilt its pitch", "[analysis]") {
  // A 98 Hz note, 93 edges on the grid, the last one 200 us late (as at full line speed): the
  // first fit's slope is 0.023 cent off (and leaves the edges next to the late one over 8 us
  // off its line too); the pitch comes from the refit without them, and the lateness shows in
  // the residuals.
  const double period = synth::kFCpuHz / 98.0;
  std::vector<uint64_t> edges = jittered_edges(93, period, 1000.0);
  const uint64_t late = uint64_t(200e-6 * synth::kFCpuHz);
  edges.back() += late;
  const PitchFit fit = fit_edges(edges, period, synth::kFCpuHz);
  CHECK(fit.pitch_edge_count < 93);
  CHECK(fit.pitch_edge_count >= 85);
  CHECK(std::fabs(fit.cents_error) < 0.001);
  CHECK(fit.residual_max_us > 190.0);
  // Half the edges or more off the line: no refit (the first fit stands).
  std::vector<uint64_t> bent = jittered_edges(10, period, 1000.0);
  for (size_t k = 5; k < bent.size(); ++k) bent[k] += late;
  CHECK(fit_edges(bent, period, synth::kFCpuHz).pitch_edge_count == bent.size());
}

TEST_CASE("the constant offset is removed from the residuals", "[analysis]") {
  std::vector<uint64_t> edges = {1000, 2010, 3000, 4010, 5000};
  std::vector<double> residual = grid_residuals_cycles(edges, 1000);
  double sum = 0;
  for (double r : residual) sum += r;
  CHECK(sum == Approx(0).margin(1e-9));
  CHECK(residual[0] == Approx(-4));
  CHECK(residual[1] == Approx(6));
  PitchFit fit = fit_edges(edges, 1000, synth::kFCpuHz);
  CHECK(fit.offset_cycles == Approx(4));
  CHECK(fit.residual_max_cycles == Approx(6));
  CHECK(fit.residual_p50_cycles == Approx(4));
}

TEST_CASE("residuals against a commanded grid carry the period's fraction and skip missing edges", "[analysis]") {
  // period 1000.5 ticks (q8 256128): the firmware's deadlines from 5000 are 5000, 6000, 7001,
  // 8001, 9002, ...
  const uint32_t period_q8 = 256128;
  const uint64_t start = 5000;
  // on their deadlines (k = 0, 1, 2), k = 3 missing, k = 4 seven cycles late, one 3 early at k = 6
  std::vector<uint64_t> edges = {5000, 6000, 7001, 9002 + 7, 11003 - 3};
  std::vector<double> r = commanded_grid_residuals_cycles(edges, start, period_q8);
  REQUIRE(r.size() == edges.size());
  CHECK(r[0] == 0);
  CHECK(r[1] == 0);
  CHECK(r[2] == 0);
  CHECK(r[3] == 7);
  CHECK(r[4] == -3);
  // the grid's own offset is kept: the same edges 40 cycles later read 40 later
  for (uint64_t &e : edges) e += 40;
  std::vector<double> shifted = commanded_grid_residuals_cycles(edges, start, period_q8);
  for (size_t k = 0; k < r.size(); ++k) CHECK(shifted[k] == r[k] + 40);
  CHECK(commanded_grid_residuals_cycles(edges, start, 0).empty());
}

TEST_CASE("fit rejects what it cannot fit", "[analysis]") {
  CHECK_THROWS_AS(fit_edges({}, 1000, synth::kFCpuHz), std::invalid_argument);
  CHECK_THROWS_AS(fit_edges({5}, 1000, synth::kFCpuHz), std::invalid_argument);
  CHECK_THROWS_AS(fit_edges({5, 10}, 0, synth::kFCpuHz), std::invalid_argument);
  CHECK_THROWS_AS(fit_edges({5, 10}, 5, 0), std::invalid_argument);
  CHECK_THROWS_AS(fit_edges({10, 10}, 5, synth::kFCpuHz), std::invalid_argument);
}

TEST_CASE("percentiles use the nearest rank", "[analysis]") {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  CHECK(percentile_nearest_rank(v, 0.5) == 50);
  CHECK(percentile_nearest_rank(v, 0.99) == 99);
  CHECK(percentile_nearest_rank(v, 1.0) == 100);
  CHECK(percentile_nearest_rank(v, 0.0) == 1);
  CHECK(percentile_nearest_rank({}, 0.5) == 0);
}

TEST_CASE("MIDI numbers and frequencies", "[analysis]") {
  CHECK(midi_from_hz(440) == Approx(69));
  CHECK(midi_from_hz(261.6255653) == Approx(60).margin(1e-6));
  CHECK(midi_from_hz(880) == Approx(81));
  CHECK(hz_from_midi(57) == Approx(220));
  CHECK(midi_from_hz(hz_from_midi(63.37)) == Approx(63.37));
}

TEST_CASE("segmentation finds the notes - legato - after silence and detuned", "[analysis]") {
  // A4, B4 legato, 0.3 s silence, A4 again, then C5 30 cents sharp legato, then a low F2
  std::vector<synth::Note> part = {{69, 0.0, 0.5},    {71, 0.5, 0.5},  {69, 1.3, 0.4},
                                   {72.3, 1.7, 0.5}, {41, 2.2, 0.6}};
  std::vector<uint64_t> cycles;
  for (const synth::Note& note : part) {
    std::vector<uint64_t> e = synth::note_edges_cycles(note);
    if (!cycles.empty() && e.front() <= cycles.back()) e.erase(e.begin());  // shared boundary instant
    cycles.insert(cycles.end(), e.begin(), e.end());
  }
  // timing jitter of +/-0.5% must not split a note
  for (size_t k = 1; k < cycles.size(); k += 7) cycles[k] += 50;
  std::vector<Step> steps = steps_at(cycles);
  std::vector<NoteSegment> notes = segment_notes(steps, synth::kFCpuHz);
  REQUIRE(notes.size() == part.size());
  for (size_t i = 0; i < part.size(); ++i) {
    INFO("note " << i);
    CHECK(notes[i].midi_note == Approx(part[i].midi_note).margin(0.01));
    CHECK(notes[i].mean_hz == Approx(hz_from_midi(part[i].midi_note)).epsilon(1e-3));
    double start_s = double(notes[i].start_cycle) / synth::kFCpuHz;
    double end_s = double(notes[i].end_cycle) / synth::kFCpuHz;
    double period_s = 1.0 / hz_from_midi(part[i].midi_note);
    CHECK(start_s == Approx(part[i].start_s).margin(1.5 * period_s));
    CHECK(end_s == Approx(part[i].start_s + part[i].duration_s).margin(1.5 * period_s));
    CHECK(notes[i].edge_count == notes[i].last_step - notes[i].first_step + 1);
    CHECK(steps[notes[i].first_step].rise_cycle == notes[i].start_cycle);
  }
  // legato notes share their boundary step; after the silence they do not
  CHECK(notes[1].first_step == notes[0].last_step);
  CHECK(notes[2].first_step == notes[1].last_step + 1);
  CHECK(notes[3].first_step == notes[2].last_step);
}

TEST_CASE("segmentation drops lone edges and handles tiny inputs", "[analysis]") {
  CHECK(segment_notes({}, synth::kFCpuHz).empty());
  CHECK(segment_notes(steps_at({100}), synth::kFCpuHz).empty());
  CHECK(segment_notes(steps_at({100, 200}), synth::kFCpuHz).empty());  // fewer than min_edges
  SegmentOptions two;
  two.min_edges = 2;
  REQUIRE(segment_notes(steps_at({100, 200}), synth::kFCpuHz, two).size() == 1);
  // one stray step long before a note is not a note, and does not shift the note
  std::vector<uint64_t> cycles = {0};
  for (int k = 0; k < 100; ++k) cycles.push_back(16000000 + uint64_t(k) * 40000);
  std::vector<NoteSegment> notes = segment_notes(steps_at(cycles), synth::kFCpuHz);
  REQUIRE(notes.size() == 1);
  CHECK(notes[0].first_step == 1);
  CHECK(notes[0].mean_hz == Approx(400));
}

TEST_CASE("window selection is half-open on rise cycles", "[analysis]") {
  std::vector<Step> steps = steps_at({10, 20, 30, 40, 50});
  IndexRange r = steps_in_window(steps, 20, 40);
  CHECK(r.begin == 1);
  CHECK(r.end == 3);
  CHECK(r.size() == 2);
  CHECK(steps_in_window(steps, 0, 1000).size() == 5);
  CHECK(steps_in_window(steps, 51, 1000).size() == 0);
  CHECK(steps_in_window(steps, 40, 20).size() == 0);
  CHECK(rise_cycles_in_window(steps, 15, 45) == std::vector<uint64_t>{20, 30, 40});
  CHECK(rise_cycles(steps).size() == 5);
}

TEST_CASE("reversals - overshoot and pulse width", "[analysis]") {
  // up 3, reverse, down 4 (to -1: overshoot 1), pause, reverse after a long stop
  std::vector<Step> steps = {{100, 1, 1, 30},  {200, 1, 2, 30},  {300, 1, 3, 30},  {400, 0, 2, 28},
                             {500, 0, 1, 30},  {600, 0, 0, 30},  {700, 0, -1, 30}, {90000, 1, 0, 31}};
  CHECK(reversal_count(steps) == 2);
  CHECK(reversal_indices(steps) == std::vector<size_t>{3, 7});
  CHECK(reversal_count(steps, 1000) == 1);  // the one after the long stop is not "while moving"
  CHECK(max_overshoot_steps(steps, 3) == 1);
  CHECK(max_overshoot_steps(steps, 1) == 2);
  CHECK(max_overshoot_steps({}, 1) == 0);
  REQUIRE(min_pulse_width_cycles(steps).has_value());
  CHECK(*min_pulse_width_cycles(steps) == 28u);
  CHECK_FALSE(min_pulse_width_cycles({}).has_value());
}

TEST_CASE("analysis of a parsed synthetic trace", "[analysis]") {
  Trace t = sc::trace::parse_trace(synth::make_trace_text(synth::three_motor_scale(), 5.5));
  std::vector<NoteSegment> notes = segment_notes(t.motor[0].steps, t.f_cpu_hz);
  REQUIRE(notes.size() == 9);
  const double expected[] = {60, 62, 64, 65, 67, 69, 71, 72, 72};
  for (size_t i = 0; i < notes.size(); ++i) CHECK(notes[i].midi_note == Approx(expected[i]).margin(0.01));
  // fit the held E4 of motor 2 against its ideal period
  std::vector<uint64_t> held = rise_cycles_in_window(t.motor[2].steps, 0, uint64_t(2.1 * t.f_cpu_hz));
  PitchFit fit = fit_edges(held, t.f_cpu_hz / hz_from_midi(64), t.f_cpu_hz);
  CHECK(std::fabs(fit.cents_error) < 0.001);
  CHECK(fit.residual_max_cycles <= 0.55);  // whole-cycle rounding only
  CHECK(reversal_count(t.motor[0].steps) >= 1);
  CHECK(max_overshoot_steps(t.motor[0].steps, t.travel_steps) == 0);
}

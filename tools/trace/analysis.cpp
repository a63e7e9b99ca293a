// analysis.cpp: pitch fit, note segmentation and motion checks on trace data (see analysis.h).
#include "analysis.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sc {
namespace trace {

constexpr double kMedianQuantile = 0.50;

double percentile_nearest_rank(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  q = std::min(1.0, std::max(0.0, q));
  size_t rank = size_t(std::ceil(q * double(values.size())));
  size_t index = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(index), values.end());
  return values[index];
}

std::vector<double> grid_residuals_cycles(const std::vector<uint64_t>& edge_cycles,
                                          double ideal_period_cycles) {
  std::vector<double> residual(edge_cycles.size());
  if (edge_cycles.empty()) return residual;
  const uint64_t first = edge_cycles.front();
  double sum = 0;
  for (size_t k = 0; k < edge_cycles.size(); ++k) {
    // integer difference first: exact, and keeps the double small
    double since_first = double(int64_t(edge_cycles[k] - first));
    residual[k] = since_first - double(k) * ideal_period_cycles;
    sum += residual[k];
  }
  const double mean = sum / double(edge_cycles.size());
  for (double& r : residual) r -= mean;
  return residual;
}

std::vector<double> commanded_grid_residuals_cycles(const std::vector<uint64_t>& edge_cycles,
                                                    uint64_t start_cycle, uint32_t period_q8) {
  std::vector<double> residual;
  residual.reserve(edge_cycles.size());
  if (period_q8 == 0) return residual;
  for (uint64_t e : edge_cycles) {
    const int64_t since = int64_t(e - start_cycle);  // may be a little before the grid's start
    const int64_t k = std::max<int64_t>(0, std::llround(double(since) * 256.0 / double(period_q8)));
    const int64_t ideal = int64_t((uint64_t(k) * period_q8) >> 8);
    residual.push_back(double(since - ideal));
  }
  return residual;
}

PitchFit fit_edges(const std::vector<uint64_t>& edge_cycles, double ideal_period_cycles,
                   double f_cpu_hz) {
  if (edge_cycles.size() < 2) throw std::invalid_argument("fit_edges: need at least 2 edges");
  if (!(ideal_period_cycles > 0)) throw std::invalid_argument("fit_edges: ideal period must be > 0");
  if (!(f_cpu_hz > 0)) throw std::invalid_argument("fit_edges: f_cpu must be > 0");
  if (edge_cycles.back() <= edge_cycles.front())
    throw std::invalid_argument("fit_edges: edges must ascend");
  PitchFit fit;
  const size_t n = edge_cycles.size();
  fit.edge_count = n;
  fit.ideal_period_cycles = ideal_period_cycles;
  // The period is the least-squares slope of edge time against edge index: every edge counts,
  // so a late first or last edge does not bias the pitch as much as first-to-last would. An
  // edge far off that line (kPitchOutlierUs: a step held up, which the residuals below report
  // as jitter) still tilts it: one edge 200 us late at the end of a 93-edge 98 Hz note moves it
  // 0.023 cent, and a few such edges made 0.05-0.11 cent in the full-line-speed e2e tests. So
  // the slope is fitted again without those, when at least half
  // the edges remain: the deadlines are absolute, so a late step does not move the ones after
  // it, and the pitch is the rate of the others. Times are relative to the first edge to keep
  // the sums exact in doubles.
  auto slope = [&](const std::vector<bool>* keep, double* intercept) {
    double m = 0, sum_k = 0, sum_t = 0, sum_kk = 0, sum_kt = 0;
    for (size_t k = 0; k < n; ++k) {
      if (keep && !(*keep)[k]) continue;
      const double t = double(edge_cycles[k] - edge_cycles.front());
      m += 1;
      sum_k += double(k);
      sum_t += t;
      sum_kk += double(k) * double(k);
      sum_kt += double(k) * t;
    }
    const double b = (m * sum_kt - sum_k * sum_t) / (m * sum_kk - sum_k * sum_k);
    *intercept = (sum_t - b * sum_k) / m;
    return b;
  };
  double intercept = 0;
  fit.mean_period_cycles = slope(nullptr, &intercept);
  fit.pitch_edge_count = n;
  const double outlier_cycles = kPitchOutlierUs * f_cpu_hz / kMicrosPerSecond;
  std::vector<bool> keep(n, true);
  size_t kept = 0;
  for (size_t k = 0; k < n; ++k) {
    const double t = double(edge_cycles[k] - edge_cycles.front());
    keep[k] = std::fabs(t - (intercept + fit.mean_period_cycles * double(k))) <= outlier_cycles;
    kept += keep[k] ? 1 : 0;
  }
  if (kept < n && kept >= 2 && 2 * kept >= n) {  // two kept edges have different indices
    fit.mean_period_cycles = slope(&keep, &intercept);
    fit.pitch_edge_count = kept;
  }
  fit.ideal_hz = f_cpu_hz / ideal_period_cycles;
  fit.measured_hz = f_cpu_hz / fit.mean_period_cycles;
  fit.cents_error = kCentsPerOctave * std::log2(ideal_period_cycles / fit.mean_period_cycles);

  std::vector<double> residual = grid_residuals_cycles(edge_cycles, ideal_period_cycles);
  // residual[0] = first - t0, so t0 - first = -residual[0]
  fit.offset_cycles = -residual[0];
  for (double& r : residual) r = std::fabs(r);
  fit.residual_max_cycles = *std::max_element(residual.begin(), residual.end());
  fit.residual_p99_cycles = percentile_nearest_rank(residual, kP99Quantile);
  fit.residual_p50_cycles = percentile_nearest_rank(std::move(residual), kMedianQuantile);
  const double us_per_cycle = kMicrosPerSecond / f_cpu_hz;
  fit.residual_p50_us = fit.residual_p50_cycles * us_per_cycle;
  fit.residual_p99_us = fit.residual_p99_cycles * us_per_cycle;
  fit.residual_max_us = fit.residual_max_cycles * us_per_cycle;
  return fit;
}

double midi_from_hz(double hz) { return kMidiA4 + kSemitonesPerOctave * std::log2(hz / kA4Hz); }

double hz_from_midi(double midi_note) {
  return kA4Hz * std::exp2((midi_note - kMidiA4) / kSemitonesPerOctave);
}

std::vector<NoteSegment> segment_notes(const std::vector<Step>& steps, double f_cpu_hz,
                                       const SegmentOptions& options) {
  std::vector<NoteSegment> notes;
  if (steps.size() < 2 || !(f_cpu_hz > 0)) return notes;
  const double gap_cycles = options.max_gap_s * f_cpu_hz;
  const size_t min_edges = std::max<size_t>(options.min_edges, 2);

  // Emits steps [first, last] as a note if it is long enough.
  auto emit = [&](size_t first, size_t last) {
    if (last < first || last - first + 1 < min_edges) return;
    NoteSegment note;
    note.first_step = first;
    note.last_step = last;
    note.start_cycle = steps[first].rise_cycle;
    note.end_cycle = steps[last].rise_cycle;
    if (note.end_cycle <= note.start_cycle) return;
    note.edge_count = last - first + 1;
    double mean_interval_cycles = double(note.end_cycle - note.start_cycle) / double(last - first);
    note.mean_hz = f_cpu_hz / mean_interval_cycles;
    note.midi_note = midi_from_hz(note.mean_hz);
    notes.push_back(note);
  };

  size_t first = 0;          // first step of the note being built
  double interval_sum = 0;   // sum of its intervals, in cycles
  size_t interval_count = 0; // how many
  for (size_t i = 0; i + 1 < steps.size(); ++i) {
    const double interval_cycles = double(steps[i + 1].rise_cycle - steps[i].rise_cycle);
    if (interval_cycles > gap_cycles) {  // silence: the note ends at step i
      emit(first, i);
      first = i + 1;
      interval_sum = 0;
      interval_count = 0;
      continue;
    }
    if (interval_count > 0) {
      const double reference_cycles = interval_sum / double(interval_count);
      if (std::fabs(interval_cycles - reference_cycles) > options.interval_tolerance * reference_cycles) {
        emit(first, i);  // pitch change: step i ends this note and starts the next
        first = i;
        interval_sum = 0;
        interval_count = 0;
      }
    }
    interval_sum += interval_cycles;
    ++interval_count;
  }
  emit(first, steps.size() - 1);
  return notes;
}

IndexRange steps_in_window(const std::vector<Step>& steps, uint64_t begin_cycle, uint64_t end_cycle) {
  auto before = [](const Step& s, uint64_t cycle) { return s.rise_cycle < cycle; };
  IndexRange range;
  range.begin = size_t(std::lower_bound(steps.begin(), steps.end(), begin_cycle, before) - steps.begin());
  if (end_cycle <= begin_cycle) {
    range.end = range.begin;
    return range;
  }
  range.end = size_t(std::lower_bound(steps.begin() + std::ptrdiff_t(range.begin), steps.end(),
                                      end_cycle, before) - steps.begin());
  return range;
}

std::vector<uint64_t> rise_cycles_in_window(const std::vector<Step>& steps, uint64_t begin_cycle,
                                            uint64_t end_cycle) {
  IndexRange range = steps_in_window(steps, begin_cycle, end_cycle);
  std::vector<uint64_t> cycles;
  cycles.reserve(range.size());
  for (size_t i = range.begin; i < range.end; ++i) cycles.push_back(steps[i].rise_cycle);
  return cycles;
}

std::vector<uint64_t> rise_cycles(const std::vector<Step>& steps) {
  return rise_cycles_in_window(steps, 0, std::numeric_limits<uint64_t>::max());
}

std::vector<size_t> reversal_indices(const std::vector<Step>& steps, uint64_t max_interval_cycles) {
  std::vector<size_t> out;
  for (size_t i = 1; i < steps.size(); ++i) {
    if (steps[i].dir != steps[i - 1].dir &&
        steps[i].rise_cycle - steps[i - 1].rise_cycle <= max_interval_cycles)
      out.push_back(i);
  }
  return out;
}

size_t reversal_count(const std::vector<Step>& steps, uint64_t max_interval_cycles) {
  return reversal_indices(steps, max_interval_cycles).size();
}

int64_t max_overshoot_steps(const std::vector<Step>& steps, int64_t travel_steps) {
  int64_t overshoot = 0;
  for (const Step& s : steps) {
    if (s.position < 0) overshoot = std::max(overshoot, -s.position);
    else if (s.position > travel_steps) overshoot = std::max(overshoot, s.position - travel_steps);
  }
  return overshoot;
}

std::optional<uint32_t> min_pulse_width_cycles(const std::vector<Step>& steps) {
  if (steps.empty()) return std::nullopt;
  uint32_t width = steps.front().width_cycles;
  for (const Step& s : steps) width = std::min(width, s.width_cycles);
  return width;
}

}  // namespace trace
}  // namespace sc

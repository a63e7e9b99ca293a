// analysis.h: pure measurements on a trace: pitch fit, note segmentation, motion checks.
#ifndef STEPCHOIR_TRACE_ANALYSIS_H
#define STEPCHOIR_TRACE_ANALYSIS_H

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "trace.h"

namespace sc {
namespace trace {

// Musical constants, defined once.
constexpr double kA4Hz = 440.0;               // concert pitch
constexpr double kMidiA4 = 69.0;              // MIDI note number of A4
constexpr double kSemitonesPerOctave = 12.0;
constexpr double kCentsPerOctave = 1200.0;
constexpr double kMicrosPerSecond = 1e6;
// fit_edges leaves edges further than this from its first least-squares line out of the
// pitch's second fit.
constexpr double kPitchOutlierUs = 8.0;

// Result of fitting a run of STEP edges against an ideal period.
struct PitchFit {
  size_t edge_count = 0;
  double ideal_period_cycles = 0;
  double mean_period_cycles = 0;   // least-squares slope of edge time against edge index,
                                   // refitted without edges over kPitchOutlierUs off the first line
  size_t pitch_edge_count = 0;     // edges in that fit
  double ideal_hz = 0;             // f_cpu_hz / ideal_period_cycles
  double measured_hz = 0;          // f_cpu_hz / mean_period_cycles
  double cents_error = 0;          // 1200 * log2(ideal_period / measured_period); + = sharp
  double offset_cycles = 0;        // t0 - first edge: the constant offset removed from the grid
  double residual_p50_cycles = 0;  // |edge - (t0 + k * ideal_period)|, 50th percentile
  double residual_p99_cycles = 0;  // same, 99th percentile (nearest rank)
  double residual_max_cycles = 0;  // same, largest
  double residual_p50_us = 0;      // the three above in microseconds
  double residual_p99_us = 0;
  double residual_max_us = 0;
};

// Fits edges (ascending CPU cycles, at least 2) against an ideal period: the measured period
// is the least-squares slope of edge time against index (edges over kPitchOutlierUs off that
// line left out of a second fit, when at least half remain). f_cpu_hz converts
// cycles to Hz and us: pass trace.f_cpu_hz for board time or trace.real_f_cpu_hz() for real
// time. Throws std::invalid_argument on fewer than 2 edges or a non-positive period/clock.
PitchFit fit_edges(const std::vector<uint64_t>& edge_cycles, double ideal_period_cycles,
                   double f_cpu_hz);

// Signed residuals of each edge against the grid t0 + k * ideal_period, t0 = their mean.
std::vector<double> grid_residuals_cycles(const std::vector<uint64_t>& edge_cycles,
                                          double ideal_period_cycles);

// Signed residuals of edges against a commanded grid, the firmware's deadlines for a note whose
// first edge is due at start_cycle: start + floor(k * period_q8 / 256) (the period's 8
// fractional bits carried), k the grid index nearest each edge. No offset is removed: a motor's
// residuals over all its notes, less their mean, are its edges against the grid with one
// constant offset removed.
std::vector<double> commanded_grid_residuals_cycles(const std::vector<uint64_t>& edge_cycles,
                                                    uint64_t start_cycle, uint32_t period_q8);

// The quantile a jitter "p99" is (percentile_nearest_rank).
constexpr double kP99Quantile = 0.99;

// Nearest-rank percentile (q in [0, 1]) of values; 0 for an empty vector.
double percentile_nearest_rank(std::vector<double> values, double q);

// A note's p99 of its edges' residuals means something from this many edges on: of fewer, the
// nearest-rank p99 is their largest (a 33 Hz note has 31 edges a second), which a max bound
// covers. Jitter p99s are judged per note from here on, and over all of a motor's edges.
constexpr size_t kMinEdgesForP99 = 100;

// MIDI note number (fractional) of a frequency: 69 + 12 * log2(hz / 440).
double midi_from_hz(double hz);

// Frequency of a (fractional) MIDI note number.
double hz_from_midi(double midi_note);

// How segment_notes splits a motor's steps into notes.
struct SegmentOptions {
  double interval_tolerance = 0.03;  // relative step-interval change that starts a new note
  double max_gap_s = 0.1;            // a step interval longer than this (board time) is silence
  size_t min_edges = 3;              // shorter runs (transitions) are dropped
};

// One note: a run of steps at a steady interval.
struct NoteSegment {
  size_t first_step = 0;      // index of the first step in the motor's step vector
  size_t last_step = 0;       // index of the last step (inclusive)
  uint64_t start_cycle = 0;   // rise cycle of the first step
  uint64_t end_cycle = 0;     // rise cycle of the last step
  size_t edge_count = 0;      // last_step - first_step + 1
  double mean_hz = 0;         // f_cpu / mean interval (board time)
  double midi_note = 0;       // midi_from_hz(mean_hz), fractional
};

// Splits one motor's steps into notes where the interval changes by more than the tolerance
// (adjacent notes share their boundary step) or a gap longer than max_gap_s appears.
std::vector<NoteSegment> segment_notes(const std::vector<Step>& steps, double f_cpu_hz,
                                       const SegmentOptions& options = SegmentOptions());

// Half-open index range [begin, end) into a step vector.
struct IndexRange {
  size_t begin = 0;
  size_t end = 0;
  // Number of steps in the range.
  size_t size() const { return end - begin; }
};

// Steps whose rise cycle lies in [begin_cycle, end_cycle) (steps must be in cycle order).
IndexRange steps_in_window(const std::vector<Step>& steps, uint64_t begin_cycle, uint64_t end_cycle);

// Rise cycles of the steps in [begin_cycle, end_cycle), ready for fit_edges.
std::vector<uint64_t> rise_cycles_in_window(const std::vector<Step>& steps, uint64_t begin_cycle,
                                            uint64_t end_cycle);

// Rise cycles of all steps.
std::vector<uint64_t> rise_cycles(const std::vector<Step>& steps);

// Indices i where steps[i] runs the other way from steps[i-1] (a reversal while moving);
// a pair further apart than max_interval_cycles is a stop and restart, not counted.
std::vector<size_t> reversal_indices(
    const std::vector<Step>& steps,
    uint64_t max_interval_cycles = std::numeric_limits<uint64_t>::max());

// Number of reversals while moving (see reversal_indices).
size_t reversal_count(const std::vector<Step>& steps,
                      uint64_t max_interval_cycles = std::numeric_limits<uint64_t>::max());

// How far the position went outside [0, travel_steps], in steps (0 if never).
int64_t max_overshoot_steps(const std::vector<Step>& steps, int64_t travel_steps);

// Shortest STEP high time, or nothing when there are no steps.
std::optional<uint32_t> min_pulse_width_cycles(const std::vector<Step>& steps);

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_ANALYSIS_H

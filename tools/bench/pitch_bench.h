// pitch_bench.h: what the pitch bench's files share: settings, the plan, a pass's results, and the steps between them.
#ifndef STEPCHOIR_TOOLS_BENCH_PITCH_BENCH_H
#define STEPCHOIR_TOOLS_BENCH_PITCH_BENCH_H

#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "board/board.h"
#include "trace.h"

namespace pitch_bench {

namespace tr = sc::trace;
using stepchoir::Status;

// Edges in the first 20 ms of each round are skipped: the change-over from the previous note (a
// sounding motor takes the new period at its first step after the round's start).
constexpr double kSettleSeconds = 0.02;
// A note further off than this (half a semitone) is a different note: the board did not play
// what was scheduled (a lost or late `at` frame); its jitter against the grid means nothing.
constexpr double kWrongNoteCents = 50;
// Board time from the clock reply to the first round: room to queue the first rounds.
constexpr double kLeadSeconds = 0.2;
constexpr double kMicrosPerSecond = 1e6;
// Other motors' edges this close before a late edge (cycles) are listed with it: the bursts the
// step ISR played or planned just before (its compare leads an edge by 1,000 ticks).
constexpr uint64_t kNeighbourCycles = 3000;

// How the host talks to the board while the music plays.
enum class Traffic { kLight, kFlood };

// Command-line settings.
struct Options {
  std::string board_name;
  std::string out_dir = "bench/results";
  double round_seconds = 0.5;
  std::vector<int> notes;  // empty: kFirstNote..kLastNote
  std::string elf_path;    // empty: the build's firmware for the board
  std::string command_line;
  // The firmware ELF the virtual board runs.
  std::string firmware_elf() const {
    return elf_path.empty() ? std::string(STEPCHOIR_FIRMWARE_DIR) + "/stepchoir-" + board_name + ".elf" : elf_path;
  }
};

// What the board is told to play: notes per round and motor, and when each round starts.
struct Plan {
  std::vector<std::vector<int>> notes_by_round;  // [round][motor] = MIDI note
  uint64_t t0_ticks = 0;                         // board time of round 0
  uint64_t round_ticks = 0;                      // length of a round in ticks
  // Board time at which round r starts.
  uint64_t round_start_ticks(size_t r) const { return t0_ticks + r * round_ticks; }
  // Board time at which the final silence starts (end of the music).
  uint64_t music_end_ticks() const { return round_start_ticks(notes_by_round.size()); }
};

// One note played by one motor in one round, measured.
struct NoteResult {
  int note = 0;
  size_t round = 0;
  size_t motor = 0;
  size_t edge_count = 0;
  bool measured = false;      // false when the window held fewer than 2 edges
  double target_hz = 0;       // equal temperament, A4 = 440 Hz
  double measured_hz = 0;     // board time
  double cents = 0;           // measured vs target
  double jitter_p99_us = 0;   // grid residuals (fit_edges)
  double jitter_max_us = 0;
  std::vector<double> residuals_us;  // |grid residual| of every edge in the window
  double min_pulse_us = 0;    // shortest STEP high time in the window
  uint64_t worst_edge_cycle = 0;   // the edge furthest off the grid (jitter_max_us)
  double worst_edge_us = 0;        // signed: + late, - early
  std::string worst_edge_others;   // other motors' edges near it, "m2 -1234" (cycles before)
};

// One ISR's line of the vboard summary.
struct IsrLine {
  int vector = 0;
  uint64_t entries = 0;
  uint64_t max_cycles = 0;
  uint64_t max_irq_off_cycles = 0;
  double load_fraction = 0;  // inclusive cycles / run cycles
};

// Everything one traffic pass produced.
struct PassResult {
  Traffic traffic = Traffic::kLight;
  std::string failure;  // why the pass produced no measurements ("" when it did)
  std::string trace_path;
  std::vector<NoteResult> notes;
  std::vector<IsrLine> isrs;
  std::optional<IsrLine> step_isr;
  uint64_t irq_off_max_cycles = 0;
  std::string irq_off_max_at;
  uint64_t irq_off_max_cycle = 0;  // when that window started
  uint64_t uart_would_overrun = 0;
  uint64_t uart_xoff = 0;
  uint64_t uart_in_lost = 0;
  double sim_seconds = 0;
  double wall_seconds = 0;
  double music_seconds = 0;
  double connect_seconds = 0;  // board time of the first clock reply (the host's first contact ~ then)
  uint64_t pacing_lag_max_us = 0;
  std::string end_reason;
  double f_cpu_hz = 16e6;
  size_t motor_count = 0;
  size_t rounds = 0;
  size_t frames_sent = 0;
  double line_use_fraction = 0;  // fraction of the line's bit rate the host used while the music played
  std::optional<Status> last_status;
  std::map<std::string, size_t> board_errors;  // error name -> count
};

// Worst values over a pass's notes (jitter over the notes played as scheduled).
struct Worst {
  double abs_cents = 0, p99_us = 0, max_us = 0, min_pulse_us = 0;
  double motor_p99_us = 0;  // over each motor's edges (of the notes played as scheduled), the worst motor
  size_t unmeasured = 0;   // fewer than 2 edges in the window
  size_t wrong_notes = 0;  // measured, but off by more than kWrongNoteCents
  size_t note_count = 0;
};

// Title of a traffic pass.
std::string traffic_title(Traffic t);
// Short name of a traffic pass (file names).
std::string traffic_tag(Traffic t);
// What the host sends in a traffic pass, for the report.
std::string traffic_description(Traffic t);
// The step ISR vectors of a board, as text for the report.
std::string step_isr_vectors(const std::string &board_name);

// Fixed-point text.
inline std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

// Cycles as microseconds on the pass's clock.
inline double cycles_us(uint64_t cycles, double f_cpu_hz) { return cycles / f_cpu_hz * kMicrosPerSecond; }

// Runs one traffic pass on a fresh virtual board and measures it (pitch_run.cpp).
PassResult run_pass(const Options &opt, const std::vector<int> &notes, Traffic traffic);
// Reads the vboard's summary lines into the pass result (pitch_analysis.cpp).
void read_vboard_summary(const tr::Trace &t, const std::string &board_name, PassResult *r);
// Measures every (round, motor) window of the trace against its note (pitch_analysis.cpp).
std::vector<NoteResult> measure_notes(const tr::Trace &t, const Plan &plan);
// True when a measured note is the scheduled one (pitch_analysis.cpp).
bool played_as_scheduled(const NoteResult &n);
// Computes the worst values of a pass (pitch_analysis.cpp).
Worst worst_of(const PassResult &r);
// Writes the report; returns its path (pitch_report.cpp).
std::string write_report(const Options &opt, const std::vector<PassResult> &passes);

}  // namespace pitch_bench

#endif  // STEPCHOIR_TOOLS_BENCH_PITCH_BENCH_H

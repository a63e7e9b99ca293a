// pitch_analysis.cpp: the pitch bench's measures: each note's pitch and jitter, the vboard's ISR summary, worst values.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "analysis.h"
#include "core/pitch.h"
#include "pitch_bench.h"
#include "trace.h"

namespace pitch_bench {

namespace {

// key=value fields of one summary line.
std::map<std::string, std::string> line_fields(const std::string &line) {
  std::istringstream in(line);
  std::map<std::string, std::string> fields;
  for (std::string token; in >> token;) {
    const size_t eq = token.find('=');
    if (eq != std::string::npos) fields[token.substr(0, eq)] = token.substr(eq + 1);
  }
  return fields;
}

// key=value fields of the first summary line holding a field that starts with `marker`.
std::map<std::string, std::string> summary_fields(const tr::Trace &t, const std::string &marker) {
  for (const std::string &line : t.summary_lines) {
    std::istringstream in(line);
    for (std::string token; in >> token;)
      if (token.rfind(marker, 0) == 0) return line_fields(line);
  }
  return {};
}

// A numeric summary field, or 0 when absent.
double field_number(const std::map<std::string, std::string> &fields, const std::string &key) {
  const auto it = fields.find(key);
  return it == fields.end() ? 0.0 : std::strtod(it->second.c_str(), nullptr);
}

}  // namespace

// The step ISRs, one timer compare channel per motor (firmware/stepchoir/scheduler.cpp): Timer1
// A/B and Timer2 A/B on the Uno, Timer1 A/B/C and Timer3 A/B on the Mega.
bool is_step_isr_vector(const std::string &board_name, int v) {
  return board_name == "mega" ? (v >= 17 && v <= 19) || v == 32 || v == 33 : v == 7 || v == 8 || v == 11 || v == 12;
}
std::string step_isr_vectors(const std::string &board_name) {
  return board_name == "mega" ? "17-19, 32, 33 (Timer1 A/B/C, Timer3 A/B)" : "7, 8, 11, 12 (Timer2 A/B, Timer1 A/B)";
}

// Reads the vboard's summary lines into the pass result.
void read_vboard_summary(const tr::Trace &t, const std::string &board_name, PassResult *r) {
  const auto irq = summary_fields(t, "irq_off_max_cycles=");
  r->irq_off_max_cycles = static_cast<uint64_t>(field_number(irq, "irq_off_max_cycles"));
  r->irq_off_max_at = irq.count("irq_off_max_at") ? irq.at("irq_off_max_at") : "";
  r->irq_off_max_cycle = static_cast<uint64_t>(field_number(irq, "irq_off_max_cycle"));
  const auto uart = summary_fields(t, "uart_would_overrun=");
  r->uart_would_overrun = static_cast<uint64_t>(field_number(uart, "uart_would_overrun"));
  r->uart_xoff = static_cast<uint64_t>(field_number(uart, "uart_xoff"));
  r->uart_in_lost = static_cast<uint64_t>(field_number(uart, "uart_in_lost"));
  const auto run = summary_fields(t, "end=");
  r->end_reason = run.count("end") ? run.at("end") : "?";
  r->sim_seconds = field_number(run, "sim_seconds");
  r->wall_seconds = field_number(run, "wall_seconds");
  r->pacing_lag_max_us = static_cast<uint64_t>(field_number(run, "pacing_lag_max_us"));
  for (const std::string &line : t.summary_lines) {
    const size_t at = line.find("isr=__vector_");
    if (at == std::string::npos) continue;
    const auto fields = line_fields(line);
    IsrLine isr;
    isr.vector = std::atoi(line.c_str() + at + 13);
    isr.entries = static_cast<uint64_t>(field_number(fields, "entries"));
    isr.max_cycles = static_cast<uint64_t>(field_number(fields, "max_cycles"));
    isr.max_irq_off_cycles = static_cast<uint64_t>(field_number(fields, "max_irq_off_cycles"));
    isr.load_fraction = field_number(fields, "load");
    r->isrs.push_back(isr);
    if (!is_step_isr_vector(board_name, isr.vector)) continue;
    // The step ISRs together: entries and loads summed (inclusive: the ISRs nested in each,
    // one another's included, count too: an upper bound), the worst invocation.
    if (!r->step_isr) r->step_isr = IsrLine{};
    IsrLine &all = *r->step_isr;
    all.entries += isr.entries;
    all.load_fraction += isr.load_fraction;
    all.max_cycles = std::max(all.max_cycles, isr.max_cycles);
    all.max_irq_off_cycles = std::max(all.max_irq_off_cycles, isr.max_irq_off_cycles);
  }
}

namespace {

// Fills n's worst edge: the one furthest off the ideal grid (the residual fit_edges' max is
// taken from), when it is, and the other motors' edges from kNeighbourCycles before it to 100
// after: the configuration that made it late.
void note_worst_edge(const tr::Trace &t, size_t motor, const std::vector<uint64_t> &edges, double period_cycles,
                     NoteResult *n) {
  const std::vector<double> residual = tr::grid_residuals_cycles(edges, period_cycles);
  if (residual.empty()) return;
  size_t worst = 0;
  for (size_t k = 1; k < residual.size(); ++k)
    if (std::abs(residual[k]) > std::abs(residual[worst])) worst = k;
  n->worst_edge_cycle = edges[worst];
  n->worst_edge_us = residual[worst] / t.f_cpu_hz * kMicrosPerSecond;
  const uint64_t edge = edges[worst];
  std::ostringstream others;
  for (size_t m = 0; m < t.motor.size(); ++m) {
    if (m == motor) continue;
    const auto &steps = t.motor[m].steps;
    const tr::IndexRange near = tr::steps_in_window(steps, edge > kNeighbourCycles ? edge - kNeighbourCycles : 0, edge + 101);
    for (size_t i = near.begin; i < near.end; ++i)
      others << (others.tellp() > 0 ? ", " : "") << "m" << m << " " << std::showpos
             << (int64_t(steps[i].rise_cycle) - int64_t(edge)) << std::noshowpos;
  }
  n->worst_edge_others = others.str();
}

}  // namespace

// Measures every (round, motor) window of the trace against its note.
std::vector<NoteResult> measure_notes(const tr::Trace &t, const Plan &plan) {
  std::vector<NoteResult> out;
  const uint64_t settle_ticks = static_cast<uint64_t>(kSettleSeconds * t.f_cpu_hz);
  for (size_t r = 0; r < plan.notes_by_round.size(); ++r) {
    for (size_t m = 0; m < plan.notes_by_round[r].size() && m < t.motor.size(); ++m) {
      NoteResult n;
      n.note = plan.notes_by_round[r][m];
      n.round = r;
      n.motor = m;
      n.target_hz = stepchoir::note_hz(n.note);
      const uint64_t from = plan.round_start_ticks(r) + settle_ticks;
      const uint64_t to = plan.round_start_ticks(r + 1);
      const auto &steps = t.motor[m].steps;
      const tr::IndexRange range = tr::steps_in_window(steps, from, to);
      n.edge_count = range.size();
      if (n.edge_count >= 2) {
        const uint32_t period_q8 = stepchoir::hz_to_period_q8(n.target_hz, static_cast<uint32_t>(t.f_cpu_hz));
        const std::vector<uint64_t> edges = tr::rise_cycles_in_window(steps, from, to);
        const tr::PitchFit fit = tr::fit_edges(edges, period_q8 / 256.0, t.f_cpu_hz);
        const std::vector<tr::Step> window(steps.begin() + range.begin, steps.begin() + range.end);
        n.measured = true;
        n.measured_hz = fit.measured_hz;
        n.cents = stepchoir::cents(fit.measured_hz, n.target_hz);
        n.jitter_p99_us = fit.residual_p99_us;
        n.jitter_max_us = fit.residual_max_us;
        for (double c : tr::grid_residuals_cycles(edges, period_q8 / 256.0))
          n.residuals_us.push_back(std::abs(c) / t.f_cpu_hz * kMicrosPerSecond);
        note_worst_edge(t, m, edges, period_q8 / 256.0, &n);
        n.min_pulse_us = *tr::min_pulse_width_cycles(window) / t.f_cpu_hz * kMicrosPerSecond;
      }
      out.push_back(n);
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const NoteResult &a, const NoteResult &b) {
    return a.note != b.note ? a.note < b.note : a.motor < b.motor;
  });
  return out;
}

// True when a measured note is the scheduled one.
bool played_as_scheduled(const NoteResult &n) { return n.measured && std::abs(n.cents) <= kWrongNoteCents; }

// Computes the worst values of a pass.
Worst worst_of(const PassResult &r) {
  Worst w;
  bool first = true;
  w.note_count = r.notes.size();
  std::vector<std::vector<double>> by_motor;
  for (const NoteResult &n : r.notes) {
    if (!n.measured) {
      ++w.unmeasured;
      continue;
    }
    w.abs_cents = std::max(w.abs_cents, std::abs(n.cents));
    w.min_pulse_us = first ? n.min_pulse_us : std::min(w.min_pulse_us, n.min_pulse_us);
    first = false;
    if (!played_as_scheduled(n)) {
      ++w.wrong_notes;
      continue;
    }
    if (n.edge_count >= tr::kMinEdgesForP99) w.p99_us = std::max(w.p99_us, n.jitter_p99_us);
    w.max_us = std::max(w.max_us, n.jitter_max_us);
    if (by_motor.size() <= n.motor) by_motor.resize(n.motor + 1);
    by_motor[n.motor].insert(by_motor[n.motor].end(), n.residuals_us.begin(), n.residuals_us.end());
  }
  // A motor's p99 as a note's: of fewer than kMinEdgesForP99 edges (most of its notes lost at
  // full line speed) it is their largest, which the max covers.
  for (const auto &v : by_motor)
    if (v.size() >= tr::kMinEdgesForP99)
      w.motor_p99_us = std::max(w.motor_p99_us, tr::percentile_nearest_rank(v, tr::kP99Quantile));
  return w;
}

}  // namespace pitch_bench

// score.cpp: checking a trace against a score, note by note.
#include "score.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "analysis.h"

namespace sc {
namespace trace {

namespace {

// Least-squares line y = a + b x. Called from: check_score.
void fit_line(const std::vector<double> &x, const std::vector<double> &y, double *a, double *b) {
  double mx = 0, my = 0;
  for (size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
  mx /= x.size(), my /= y.size();
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  *b = sxx > 0 ? sxy / sxx : 1.0;
  *a = my - *b * mx;
}

}  // namespace

ScoreCheck check_score(const Trace &t, const std::vector<ScoreNote> &notes, std::FILE *detail) {
  ScoreCheck c;
  c.notes = notes.size();
  const double f = t.real_f_cpu_hz();
  auto sec = [&](uint64_t cycle) { return static_cast<double>(cycle) / f; };
  // Notes that start on a silent motor (for at least 8 ms, a restrike's gap included) begin
  // after a gap in its steps: unambiguous. The offset that lines the most of them up with such
  // starts (within 5 ms) is the rough one; their onsets near it fix the line (with one only,
  // the tempo is taken as exact).
  std::vector<size_t> fresh;
  std::vector<bool> is_fresh(notes.size(), false);
  for (size_t k = 0; k < notes.size(); ++k) {
    bool silent_before = true;
    for (size_t q = 0; q < k; ++q)
      if (notes[q].motor == notes[k].motor && notes[q].off_s > notes[k].on_s - 0.008)
        silent_before = false;
    if (notes[k].after_silence >= 0) silent_before = notes[k].after_silence == 1;
    if (silent_before) fresh.push_back(k), is_fresh[k] = true;
  }
  std::vector<std::vector<size_t>> start_cache(t.motor.size());
  std::vector<bool> cached(t.motor.size(), false);
  auto start_steps = [&](size_t motor) -> const std::vector<size_t> & {  // steps that follow a gap (indices)
    if (cached.at(motor)) return start_cache[motor];
    std::vector<size_t> &out = start_cache[motor];
    const auto &s = t.motor.at(motor).steps;
    for (size_t i = 0; i < s.size(); ++i) {
      const double gap = i == 0 ? 1e9 : sec(s[i].rise_cycle) - sec(s[i - 1].rise_cycle);
      const double before = i < 2 ? 0 : sec(s[i - 1].rise_cycle) - sec(s[i - 2].rise_cycle);
      if (gap > 0.008 && gap > 1.5 * before) out.push_back(i);
    }
    cached[motor] = true;
    return out;
  };
  auto starts = [&](size_t motor) {  // their times
    std::vector<double> out;
    for (size_t i : start_steps(motor)) out.push_back(sec(t.motor.at(motor).steps[i].rise_cycle));
    return out;
  };
  auto start_near = [&](size_t k, double offset, double tolerance, double *at) {
    for (double x : starts(notes[k].motor))
      if (std::fabs(x - offset - notes[k].on_s) < tolerance) return *at = x, true;
    return false;
  };
  if (fresh.empty()) {
    c.first_problem = "no note starts on a silent motor";
    return c;
  }
  // Whether the motor steps at note k's pitch (within 2 %) in the middle of it, for an offset.
  auto sounds_right = [&](size_t k, double offset) {
    const auto &s = t.motor.at(notes[k].motor).steps;
    const double mid = offset + 0.5 * (notes[k].on_s + notes[k].off_s);
    const auto it = std::lower_bound(s.begin(), s.end(), mid, [&](const Step &st, double v) { return sec(st.rise_cycle) < v; });
    if (it == s.begin() || it == s.end()) return false;
    const double interval = sec(it->rise_cycle) - sec((it - 1)->rise_cycle);
    return std::fabs(interval * hz_from_midi(notes[k].midi_note) - 1.0) < 0.02;
  };
  // Candidates: every start after a gap on the first fresh note's motor. The one under which
  // the most fresh notes start on time and then the most notes sound at their pitch wins (a
  // repeating bass line alone would line up at several offsets).
  double rough = 0;
  size_t best = 0;
  for (double x : starts(notes[fresh[0]].motor)) {
    const double offset = x - notes[fresh[0]].on_s;
    size_t lined_up = 0, in_tune = 0;
    double at;
    for (size_t k : fresh) lined_up += start_near(k, offset, 0.005, &at);
    for (size_t k = 0; k < notes.size(); ++k) in_tune += sounds_right(k, offset);
    const size_t score = lined_up * (notes.size() + 1) + in_tune;
    if (score > best)
      best = score, rough = offset, c.offsets_tied = 0;
    else if (score == best && best > 0)
      ++c.offsets_tied;
  }
  std::vector<double> xs, ys;
  for (size_t k : fresh) {
    double at;
    if (start_near(k, rough, 0.005, &at)) xs.push_back(notes[k].on_s), ys.push_back(at);
  }
  if (xs.empty()) {
    c.first_problem = "no note starts on a silent motor where the trace shows one";
    return c;
  }
  double a = ys[0] - xs[0], b = 1;
  if (xs.size() >= 2) fit_line(xs, ys, &a, &b);
  // Every note's onset edge on that line, then the line again through all of them. A note on a
  // silent motor begins with the step after the gap nearest the line (within 5 ms), however far
  // the line is off; a note that follows another (struck on its time) with the step nearest the
  // line, within half its period, after which its period runs (a strike a little off the line is
  // still its onset, and an old note's step nearer the line is not).
  auto onset_edge = [&](const ScoreNote &n) -> long {
    const auto &s = t.motor.at(n.motor).steps;
    const size_t k = static_cast<size_t>(&n - notes.data());
    if (is_fresh[k]) {
      const std::vector<size_t> &st = start_steps(n.motor);
      const double want = a + b * n.on_s;
      auto it = std::lower_bound(st.begin(), st.end(), want - 0.005,
                                 [&](size_t i, double v) { return sec(s[i].rise_cycle) < v; });
      long best_i = -1;
      double best_off = 0.005;
      for (; it != st.end() && sec(s[*it].rise_cycle) < want + 0.005; ++it) {
        const double off = std::fabs(sec(s[*it].rise_cycle) - want);
        if (off < best_off) best_off = off, best_i = static_cast<long>(*it);
      }
      if (best_i >= 0) return best_i;
    }
    const double want = a + b * n.on_s;
    const double period = 1 / hz_from_midi(n.midi_note);
    auto it = std::lower_bound(s.begin(), s.end(), want - period / 2, [&](const Step &st, double v) {
      return sec(st.rise_cycle) < v;
    });
    long best_i = -1, best_run_i = -1;
    double best_off = 0, best_run_off = 0;
    for (; it != s.end() && sec(it->rise_cycle) <= want + period / 2; ++it) {
      const double at = sec(it->rise_cycle), off = std::fabs(at - want);
      const long i = static_cast<long>(it - s.begin());
      if (best_i < 0 || off < best_off) best_off = off, best_i = i;
      // The note's own period follows its first step (within 3 %, half a semitone).
      const bool runs = it + 1 != s.end() && std::fabs(sec((it + 1)->rise_cycle) - at - period) < 0.03 * period;
      if (runs && (best_run_i < 0 || off < best_run_off)) best_run_off = off, best_run_i = i;
    }
    if (best_run_i >= 0) return best_run_i;
    if (best_i >= 0) return best_i;
    // None within half a period (a note that came late by more): its first step after the time.
    it = std::lower_bound(s.begin(), s.end(), want, [&](const Step &st, double v) { return sec(st.rise_cycle) < v; });
    return it == s.end() ? -1 : static_cast<long>(it - s.begin());
  };
  xs.clear(), ys.clear();
  for (const ScoreNote &n : notes) {
    const long i = onset_edge(n);
    if (i >= 0) xs.push_back(n.on_s), ys.push_back(sec(t.motor[n.motor].steps[static_cast<size_t>(i)].rise_cycle));
  }
  fit_line(xs, ys, &a, &b);
  c.tempo_ppm = (b - 1.0) * 1e6;
  c.line_offset_s = a;
  std::vector<double> cents;
  for (size_t k = 0; k < notes.size(); ++k) {
    const ScoreNote &n = notes[k];
    const auto &s = t.motor[n.motor].steps;
    const long i = onset_edge(n);
    if (i < 0) {
      if (c.first_problem.empty()) c.first_problem = "note " + std::to_string(k) + ": no steps";
      continue;
    }
    auto board = [&](double song_s) { return a + b * song_s; };
    const double err_us = (sec(s[static_cast<size_t>(i)].rise_cycle) - board(n.on_s)) * 1e6;
    c.onset_err_us.push_back(err_us);
    if (std::fabs(err_us) > 100 && c.first_problem.empty())
      c.first_problem = "note " + std::to_string(k) + " (motor " + std::to_string(n.motor) + ", " +
                        std::to_string(n.on_s) + " s): onset off by " + std::to_string(err_us) + " us";
    // The note's edges: up to its end, and never the onset step of the motor's next note (a
    // strike a little before the line is that note's, not this one's).
    size_t stop = s.size();
    for (size_t q = k + 1; q < notes.size(); ++q)
      if (notes[q].motor == n.motor && notes[q].on_s >= n.off_s - 1e-9) {
        const long next = onset_edge(notes[q]);
        if (next > i) stop = static_cast<size_t>(next);
        break;
      }
    std::vector<uint64_t> edges;
    size_t j = static_cast<size_t>(i);
    for (; j < stop && sec(s[j].rise_cycle) < board(n.off_s) - 0.00005; ++j) edges.push_back(s[j].rise_cycle);
    if (edges.empty()) {  // the motor's next edge comes after the note's end: not played
      if (c.first_problem.empty()) c.first_problem = "note " + std::to_string(k) + ": no steps while it lasts";
      continue;
    }
    ++c.found;
    const double hz = hz_from_midi(n.midi_note);
    const double period_s = 1.0 / hz;
    // A motor that reaches the end of its travel turns round: the steps around the turn are
    // no measure of pitch (bounce-back is checked elsewhere).
    bool turned = false;
    for (const auto &d : t.motor[n.motor].dir_changes)
      turned = turned || (d.cycle >= edges.front() && d.cycle <= edges.back());
    c.turned += turned;
    double cents_error = 0;
    if (edges.size() >= 3 && !turned) {
      cents_error = fit_edges(edges, f / hz, f).cents_error;
      cents.push_back(cents_error);
      c.max_cents = std::max(c.max_cents, std::fabs(cents_error));
    }
    if (detail)
      std::fprintf(detail, "note %zu motor %zu %.4f-%.4f s pitch %.2f: onset %+.1f us, %zu edges%s, %+.4f cent, ends %.1f us early\n",
                   k, n.motor, n.on_s, n.off_s, n.midi_note, err_us, edges.size(), turned ? " (turned round)" : "",
                   cents_error, (board(n.off_s) - (sec(edges.back()) + period_s)) * 1e6);
    const double last = sec(edges.back());
    c.max_release_early_us = std::max(c.max_release_early_us, (board(n.off_s) - (last + period_s)) * 1e6);
    // The motor's next note (if legato, it starts at this one's end).
    double next_on = 1e9;
    for (size_t q = k + 1; q < notes.size(); ++q)
      if (notes[q].motor == n.motor) {
        next_on = notes[q].on_s;
        break;
      }
    if (j < s.size()) {
      const double after = sec(s[j].rise_cycle);
      if (after < board(next_on) - 0.0005)
        c.max_release_late_us = std::max(c.max_release_late_us, (after - board(n.off_s)) * 1e6);
    }
  }
  if (!cents.empty()) {
    std::vector<double> sorted = cents;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    for (double x : cents) c.max_spread_cents = std::max(c.max_spread_cents, std::fabs(x - sorted[sorted.size() / 2]));
  }
  return c;
}


namespace {

// A number from the trace's summary ("key=N"), -1 when absent.
long summary_value(const Trace &t, const std::string &key) {
  for (const std::string &line : t.summary_lines) {
    const size_t at = line.find(" " + key + "=");
    if (at != std::string::npos) return std::atol(line.c_str() + at + key.size() + 2);
  }
  return -1;
}

}  // namespace

long pacing_slipped_us(const Trace &t) { return summary_value(t, "pacing_slipped_us"); }

long pacing_lag_max_us(const Trace &t) { return summary_value(t, "pacing_lag_max_us"); }

long uart_in_lost(const Trace &t) { return summary_value(t, "uart_in_lost"); }

double pacing_lag_max_s(const Trace &t) {
  const long cycle = summary_value(t, "pacing_lag_max_cycle");
  return cycle < 0 ? -1.0 : t.real_seconds(static_cast<uint64_t>(cycle));
}

}  // namespace trace
}  // namespace sc

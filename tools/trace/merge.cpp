// merge.cpp: several boards' traces on one time line.
#include "merge.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace sc {
namespace trace {

namespace {

// The cycle of a trace's first STEP edge, or none.
bool first_step(const Trace &t, uint64_t *cycle) {
  bool any = false;
  for (const MotorTrace &m : t.motor)
    if (!m.steps.empty() && (!any || m.steps.front().rise_cycle < *cycle)) *cycle = m.steps.front().rise_cycle, any = true;
  return any;
}

void shift(std::vector<LevelChange> &changes, uint64_t by) {
  for (LevelChange &c : changes) c.cycle += by;
}

}  // namespace

Trace merge_traces(const std::vector<Trace> &traces, const std::vector<double> &first_note_s) {
  if (traces.empty() || traces.size() != first_note_s.size())
    throw std::runtime_error("merge: one first-note time per trace is needed");
  // The cycle of song time 0 on each board; the merged line puts every one at the latest.
  std::vector<double> zero(traces.size(), 0.0);
  double latest = 0;
  for (size_t k = 0; k < traces.size(); ++k) {
    const Trace &t = traces[k];
    if (t.f_cpu_hz != traces[0].f_cpu_hz || t.clock_ppm != traces[0].clock_ppm)
      throw std::runtime_error("merge: trace " + std::to_string(k + 1) +
                               " runs at another clock (f_cpu or clock_ppm) than the first");
    uint64_t first = 0;
    zero[k] = first_step(t, &first) ? static_cast<double>(first) - first_note_s[k] * t.f_cpu_hz : 0.0;
    latest = std::max(latest, zero[k]);
  }
  Trace out;
  out.f_cpu_hz = traces[0].f_cpu_hz;
  out.clock_ppm = traces[0].clock_ppm;
  out.has_end = true;
  for (size_t k = 0; k < traces.size(); ++k) {
    const Trace &t = traces[k];
    const uint64_t by = static_cast<uint64_t>(std::llround(latest - zero[k]));
    out.board += (k ? "+" : "") + t.board;
    out.motors += t.motors;
    out.travel_steps = std::max(out.travel_steps, t.travel_steps);
    out.end_cycle = std::max(out.end_cycle, t.end_cycle + by);
    out.has_end = out.has_end && t.has_end;
    for (MotorTrace m : t.motor) {
      for (Step &s : m.steps) s.rise_cycle += by;
      for (auto *list : {&m.dir_changes, &m.endstop_changes, &m.bounces, &m.enables, &m.sleeps, &m.resets})
        shift(*list, by);
      out.motor.push_back(std::move(m));
    }
    for (uint64_t r : t.mcu_resets) out.mcu_resets.push_back(r + by);
    out.summary_lines.insert(out.summary_lines.end(), t.summary_lines.begin(), t.summary_lines.end());
  }
  std::sort(out.mcu_resets.begin(), out.mcu_resets.end());
  return out;
}

}  // namespace trace
}  // namespace sc

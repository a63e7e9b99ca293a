// baseline_plan.cpp: the song planner before the arranger, kept as the arrangement
// benchmark's baseline (tools/bench/arrange_bench.cpp): notes in onset order, each to the best
// free motor (no folding, then its line's motor, else the one idle longest); with every motor
// busy a note nearly done (70 %) is cut short, else the new note is left out. Percussion is
// sung as pitches, as every note is.
#include "baseline_plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace stepchoir {

namespace {

// What a motor is doing while the plan is built.
struct MotorLine {
  double busy_until = -1;      // end of its latest note
  double last_on = -1;
  int last_track = -1, last_channel = -1;
  double last_pitch = 0;
  long last_note = -1;         // index into Plan::notes of its latest note
};

}  // namespace

Plan plan_song_baseline(const Song &song, const PlanOptions &o) {
  if (o.motors.empty()) throw std::invalid_argument("no motor to play the song");
  if (!(o.tempo_scale > 0) || !std::isfinite(o.tempo_scale))
    throw std::invalid_argument("tempo scale must be above 0");
  if (!(o.start_s >= 0)) throw std::invalid_argument("start position must be 0 or later");
  Plan plan;
  plan.duration_s = std::max(0.0, (song.duration_s - o.start_s) / o.tempo_scale);
  std::vector<MotorLine> lines(o.motors.size());
  const double eps = 1e-9;
  for (uint32_t i = 0; i < song.notes.size(); ++i) {
    const SongNote &n = song.notes[i];
    if (!note_selected(n, o)) continue;
    const double end = n.onset_s + n.duration_s;
    ++plan.selected;
    const double on = (std::max(n.onset_s, o.start_s) - o.start_s) / o.tempo_scale;
    const double off = (end - o.start_s) / o.tempo_scale;
    if (off - on < o.min_note_s) {
      plan.unplayed.push_back({i, Unplayed::kTooShort});
      continue;
    }
    const int key = static_cast<int>(n.midi_note) + o.transpose;
    // The best free motor: one that plays the note without folding; then one that last
    // played this line (track and channel), nearest in pitch; else the one idle longest (one
    // never used first).
    long best = -1;
    int best_octaves = 0, best_class = 0;
    double best_cost = 0;
    uint8_t best_played = 0;
    bool any_range = false;
    for (size_t m = 0; m < lines.size(); ++m) {
      if (key < 0 || key > 127) break;
      uint8_t played = 0;
      int octaves = 0;
      if (!resolve_note(o.motors[m], static_cast<uint8_t>(key), &played, &octaves)) continue;
      any_range = true;
      const MotorLine &l = lines[m];
      if (l.busy_until > on + eps) continue;
      const bool same_line = l.last_track == n.track && l.last_channel == n.channel;
      const int cls = same_line ? 0 : 1;
      const double cost = same_line ? std::fabs(l.last_pitch - played) : l.busy_until;
      if (best < 0 || octaves < best_octaves || (octaves == best_octaves && (cls < best_class || (cls == best_class && cost < best_cost)))) {
        best = static_cast<long>(m);
        best_octaves = octaves;
        best_class = cls;
        best_cost = cost;
        best_played = played;
      }
    }
    if (!any_range) {
      plan.unplayed.push_back({i, Unplayed::kOutOfRange});
      continue;
    }
    if (best < 0) {
      // Every motor busy. Cut short a note that is mostly played (at least 70 %), the one that
      // ends soonest; otherwise this note is left out: stealing as rarely as possible keeps
      // the lines that are already sounding whole.
      double soonest = std::numeric_limits<double>::infinity();
      for (size_t m = 0; m < lines.size(); ++m) {
        const MotorLine &l = lines[m];
        uint8_t played = 0;
        int octaves = 0;
        if (key < 0 || key > 127 || !resolve_note(o.motors[m], static_cast<uint8_t>(key), &played, &octaves)) continue;
        const double length = l.busy_until - l.last_on;
        if (on - l.last_on < 0.7 * length || on - l.last_on < o.min_note_s) continue;
        if (l.busy_until < soonest) soonest = l.busy_until, best = static_cast<long>(m), best_played = played;
      }
      if (best < 0) {
        plan.unplayed.push_back({i, Unplayed::kNoMotor});
        continue;
      }
      plan.notes[static_cast<size_t>(lines[best].last_note)].off_s = on;
      ++plan.shortened;
    }
    MotorLine &l = lines[static_cast<size_t>(best)];
    const double pitch = best_played + o.motors[static_cast<size_t>(best)].tuning_cents / 100.0;
    // The same pitch again right after the last note: leave a gap so it strikes again.
    if (l.last_note >= 0 && std::fabs(l.last_pitch - best_played) < 0.5 && on - l.busy_until < kRestrikeGapS) {
      PlannedNote &prev = plan.notes[static_cast<size_t>(l.last_note)];
      prev.off_s = std::max(prev.on_s + 0.5 * (on - prev.on_s), on - kRestrikeGapS);
    }
    l.busy_until = off;
    l.last_on = on;
    l.last_track = n.track;
    l.last_channel = n.channel;
    l.last_pitch = best_played;
    l.last_note = static_cast<long>(plan.notes.size());
    plan.notes.push_back({on, off, static_cast<uint8_t>(best), pitch, i});
  }
  return plan;
}

}  // namespace stepchoir

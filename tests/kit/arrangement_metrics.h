// arrangement_metrics.h: how much of a song a plan lets a listener hear, for the arranger's
// tests and its benchmark (tools/bench/arrange_bench.cpp).
//
// Melody coverage: the share of the time during which the song has a pitched note sounding
// that its highest sounding pitched note's pitch class also sounds on some motor. Bass
// coverage: the same for the lowest. Drum hits sung: percussion notes played as pitches.
// Measured on the plan's time line; the plan must be made with tempo 1 and start 0.
#ifndef STEPCHOIR_TESTS_KIT_ARRANGEMENT_METRICS_H
#define STEPCHOIR_TESTS_KIT_ARRANGEMENT_METRICS_H

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <set>
#include <utility>
#include <vector>

#include "player/plan.h"
#include "song/song.h"

namespace stepchoir::kit {

struct ArrangementFigures {
  double melody = 0, bass = 0;  // coverage, 0-1
  size_t drum_hits_sung = 0;
  size_t dropped = 0;           // selected notes the plan does not play (percussion included)
  size_t percussion = 0;        // percussion notes in the song
  size_t notes = 0;             // notes in the song
};

// Called from: the arranger tests, the arrangement benchmark.
inline ArrangementFigures measure_arrangement(const Song &song, const Plan &plan) {
  ArrangementFigures f;
  f.notes = song.notes.size();
  f.dropped = plan.unplayed.size();
  struct Edge {
    double t;
    bool on, planned;
    size_t i;
  };
  std::vector<Edge> edges;
  for (size_t i = 0; i < song.notes.size(); ++i) {
    const SongNote &n = song.notes[i];
    if (n.percussion) {
      ++f.percussion;
      continue;
    }
    edges.push_back({n.onset_s, true, false, i});
    edges.push_back({n.onset_s + n.duration_s, false, false, i});
  }
  for (size_t i = 0; i < plan.notes.size(); ++i) {
    const PlannedNote &p = plan.notes[i];
    if (song.notes[p.song_index].percussion) {
      if (p.role != Role::kPercussion) ++f.drum_hits_sung;
      continue;
    }
    edges.push_back({p.on_s, true, true, i});
    edges.push_back({p.off_s, false, true, i});
  }
  std::sort(edges.begin(), edges.end(), [](const Edge &a, const Edge &b) {
    return a.t != b.t ? a.t < b.t : a.on < b.on;  // ends first
  });
  std::multiset<int> sounding;  // the song's pitched keys
  int classes[12] = {};         // pitch classes sounding on motors
  double texture = 0, melody = 0, bass = 0;
  for (size_t e = 0; e < edges.size(); ++e) {
    const Edge &ed = edges[e];
    if (ed.planned) {
      const int pc = static_cast<int>(std::lround(plan.notes[ed.i].pitch)) % 12;
      classes[pc] += ed.on ? 1 : -1;
    } else if (ed.on) {
      sounding.insert(song.notes[ed.i].midi_note);
    } else {
      sounding.erase(sounding.find(song.notes[ed.i].midi_note));
    }
    if (e + 1 == edges.size() || sounding.empty()) continue;
    const double span = edges[e + 1].t - ed.t;
    if (span <= 0) continue;
    texture += span;
    if (classes[*sounding.rbegin() % 12] > 0) melody += span;
    if (classes[*sounding.begin() % 12] > 0) bass += span;
  }
  f.melody = texture > 0 ? melody / texture : 1;
  f.bass = texture > 0 ? bass / texture : 1;
  return f;
}

}  // namespace stepchoir::kit

#endif  // STEPCHOIR_TESTS_KIT_ARRANGEMENT_METRICS_H

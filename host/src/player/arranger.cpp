// arranger.cpp: melody, bass and inner voices from the texture's top and bottom; the order in
// which the planner offers motors.
#include "player/arranger.h"

#include <algorithm>
#include <cctype>
#include <set>
#include <utility>

namespace stepchoir {

namespace {

// A note is melody (bass) when it is at the top (bottom) for at least this share of its length.
constexpr double kLineShare = 0.5;

// The top and bottom time of every pitched note (of track `only`, when it is >= 0), into top
// and bottom: a sweep over the notes' ends, keeping the sounding set ordered by key. Called
// from: arrange_notes.
void measure_texture(const std::vector<ArrangedNote> &notes, long only, std::vector<double> &top,
                     std::vector<double> &bottom) {
  top.assign(notes.size(), 0);
  bottom.assign(notes.size(), 0);
  struct Edge {
    double t;
    bool on;
    uint32_t i;
  };
  std::vector<Edge> edges;
  edges.reserve(notes.size() * 2);
  for (uint32_t i = 0; i < notes.size(); ++i) {
    // (A note of no length would never leave the sounding set: ends sort before starts.)
    if (notes[i].role == Role::kPercussion || (only >= 0 && notes[i].track != only) ||
        !(notes[i].off_s > notes[i].on_s))
      continue;
    edges.push_back({notes[i].on_s, true, i});
    edges.push_back({notes[i].off_s, false, i});
  }
  // By time; at one time ends before starts, so that legato notes do not overlap.
  std::sort(edges.begin(), edges.end(), [](const Edge &a, const Edge &b) {
    return a.t != b.t ? a.t < b.t : (a.on != b.on ? !a.on : a.i < b.i);
  });
  std::set<std::pair<int, uint32_t>> sounding;  // (key, index)
  for (size_t e = 0; e < edges.size(); ++e) {
    const Edge &ed = edges[e];
    if (ed.on) sounding.insert({notes[ed.i].key, ed.i});
    else sounding.erase({notes[ed.i].key, ed.i});
    if (sounding.empty() || e + 1 == edges.size()) continue;
    const double span = edges[e + 1].t - ed.t;
    if (span <= 0) continue;
    // Of a unison at the top, the first note of the file counts.
    const int top_key = sounding.rbegin()->first;
    top[sounding.lower_bound({top_key, 0})->second] += span;
    bottom[sounding.begin()->second] += span;
  }
}

// How much an inner voice adds, for its place in the order. Called from: arrange_notes.
double weight(const ArrangedNote &n, const SongNote &s) {
  const double length = n.off_s - n.on_s;
  return length * (0.5 + s.velocity / 254.0) + 2 * (n.top_s + n.bottom_s);
}

}  // namespace

bool lead_track_name(const std::string &name) {
  std::string lower;
  for (char c : name) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char *word : {"lead", "melod", "vocal", "solo"})
    if (lower.find(word) != std::string::npos) return true;
  return false;
}

std::vector<uint32_t> arrange_notes(std::vector<ArrangedNote> &notes, const Song &song, const PlanOptions &o) {
  std::vector<double> top, bottom, lead_top, unused;
  measure_texture(notes, -1, top, bottom);
  for (size_t i = 0; i < notes.size(); ++i) notes[i].top_s = top[i], notes[i].bottom_s = bottom[i];
  // A track named as the lead: only when one track alone is (several "solo" tracks are parts).
  long lead = -1;
  for (size_t t = 0; t < song.track_names.size(); ++t)
    if (lead_track_name(song.track_names[t])) lead = lead == -1 ? static_cast<long>(t) : -2;
  // Of the lead track, its own highest line (a harmonised lead has inner notes too).
  if (lead >= 0) measure_texture(notes, lead, lead_top, unused);
  for (ArrangedNote &n : notes) {
    if (n.role == Role::kPercussion) continue;
    const SongNote &s = song.notes[n.song_index];
    const double length = n.off_s - n.on_s;
    const bool lead_line = s.track == lead && lead_top[static_cast<size_t>(&n - notes.data())] >= kLineShare * length;
    if (lead_line || n.top_s >= kLineShare * length) n.role = Role::kMelody;
    else if (n.bottom_s >= kLineShare * length) n.role = Role::kBass;
    else n.role = Role::kInner;
    for (size_t v = 0; v < o.voices.size(); ++v)
      if (o.voices[v].value == (o.voices[v].by_channel ? s.channel : s.track)) {
        n.named = static_cast<int>(v);
        break;
      }
  }
  // Rank: named lines in their order, then melody, bass, inner. Onset order within a line
  // (at one onset the outer note first); inner voices by weight.
  const int lines = static_cast<int>(o.voices.size());
  auto rank = [&](const ArrangedNote &n) {
    if (n.named >= 0) return n.named;
    return lines + (n.role == Role::kMelody ? 0 : n.role == Role::kBass ? 1 : 2);
  };
  std::vector<uint32_t> order;
  order.reserve(notes.size());
  for (uint32_t i = 0; i < notes.size(); ++i)
    if (notes[i].role != Role::kPercussion) order.push_back(i);
  std::vector<double> weights(notes.size(), 0);
  for (uint32_t i : order) weights[i] = weight(notes[i], song.notes[notes[i].song_index]);
  // One rank holds one kind of line: a named line (any roles), the melody, the bass, or the
  // inner voices. The comparison looks at the rank alone, so that it stays a strict order.
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const ArrangedNote &x = notes[a], &y = notes[b];
    const int rx = rank(x), ry = rank(y);
    if (rx != ry) return rx < ry;
    if (rx == lines + 2 && weights[a] != weights[b]) return weights[a] > weights[b];
    if (rx != lines + 2 && x.on_s != y.on_s) return x.on_s < y.on_s;
    if (x.key != y.key) return rx == lines + 1 ? x.key < y.key : x.key > y.key;
    return a < b;
  });
  return order;
}

}  // namespace stepchoir

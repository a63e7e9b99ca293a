// plan.cpp: a song's notes to motors, in the arranger's order: each note takes the motor that
// keeps its line together, or the part of a motor's time that is free, or is left out with a
// reason; percussion goes to the drum motor as bursts.
#include "player/plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

#include "player/arranger.h"
#include "player/drum_voice.h"

namespace stepchoir {

namespace {

constexpr double kEps = 1e-9;
constexpr double kInf = std::numeric_limits<double>::infinity();
// A note is a doubling of one already placed when that one starts at most kDoublingEarlyS
// before it and kDoublingLateS after it (or a quarter of its length, if less), and ends no
// earlier than kDoublingEarlyS before it ends.
constexpr double kDoublingEarlyS = 0.02, kDoublingLateS = 0.005;
// A motor whose nearest note is further than this from a new note counts as free of other lines.
constexpr double kLineGapS = 1.0;
// A note placed in part (a note placed before it holds the motor later on) keeps at least this
// share of its length, unless it is melody or bass or is ever the highest or lowest note, which
// keep any part.
constexpr double kInnerPartShare = 0.5;
// A note of the same rank that is at least this far through its length gives way to a new one.
constexpr double kStealShare = 0.7;

// True when v is in list. Called from: note_selected.
bool listed(const std::vector<int> &list, int v) { return std::find(list.begin(), list.end(), v) != list.end(); }

// Places notes on motors; every decision of plan_song after the arranger's order.
class Placer {
 public:
  // Called from: plan_song.
  Placer(const PlanOptions &o, Plan &plan) : o_(o), plan_(plan), busy_(o.motors.size()) {}

  // Places note n (its rank in the order: rank), or records why not. A unison or octave of a
  // note already placed waits for place_doublings. One that goes on after the note it doubles
  // takes a free motor if there is one, and otherwise holds that note on. Called from:
  // plan_song, in the arranger's order.
  void place(const ArrangedNote &n, int rank) {
    if (doubled(n)) {
      doublings_.push_back({&n, rank});
      return;
    }
    place_now(n, rank, extends(n));
  }

  // The doublings place left, on motors nothing else wants: each on a free motor if there is
  // one (a unison is louder), else merged into the note it doubles. Called from: plan_song,
  // after every place.
  void place_doublings() {
    for (const auto &[n, rank] : doublings_) place_now(*n, rank, true);
  }

  // Places the percussion hits (by onset) on the drum motor as bursts. Called from: plan_song.
  void place_drums(std::vector<const ArrangedNote *> hits, const Song &song) {
    const size_t m = static_cast<size_t>(o_.drum_motor);
    std::stable_sort(hits.begin(), hits.end(), [&](const ArrangedNote *a, const ArrangedNote *b) {
      if (a->on_s != b->on_s) return a->on_s < b->on_s;
      return drum_burst(song.notes[a->song_index].midi_note).rank < drum_burst(song.notes[b->song_index].midi_note).rank;
    });
    long last = -1;
    for (const ArrangedNote *h : hits) {
      const DrumBurst b = drum_burst(song.notes[h->song_index].midi_note);
      uint8_t played = 0;
      int octaves = 0;
      if (!resolve_note(o_.motors[m], b.note, &played, &octaves)) {
        unplayed(*h, Unplayed::kOutOfRange);
        continue;
      }
      if (last >= 0 && h->on_s - plan_.notes[static_cast<size_t>(last)].on_s < kDrumHitGapS) {
        unplayed(*h, Unplayed::kDrumTogether);
        continue;
      }
      if (last >= 0) {
        PlannedNote &prev = plan_.notes[static_cast<size_t>(last)];
        prev.off_s = std::min(prev.off_s, h->on_s);
      }
      last = static_cast<long>(plan_.notes.size());
      add(m, *h, std::min(h->on_s + b.length_s, plan_.duration_s), played, b.note, -3, 0);
    }
  }

  // Records a note left out. Called from: place, place_drums, plan_song.
  void unplayed(const ArrangedNote &n, Unplayed why) { plan_.unplayed.push_back({n.song_index, why}); }

 private:
  // place's work. doubling: n doubles a placed note (a unison or octave of it, or one it can
  // hold on): it takes a free motor or merges into that note, never a part of a motor's time
  // or another note's motor.
  void place_now(const ArrangedNote &n, int rank, bool doubling) {
    const int line = line_of(n);
    long best = -1;
    double best_until = 0;
    uint8_t best_played = 0;
    bool any_range = false;
    std::tuple<int, int, double, double> best_score{};
    long part = -1, steal = -1;  // the motor with the longest free part; one to take from
    double part_until = 0, steal_until = 0, steal_end = kInf;
    uint8_t part_played = 0, steal_played = 0;
    for (size_t m = 0; m < busy_.size(); ++m) {
      if (static_cast<int>(m) == o_.drum_motor) continue;
      uint8_t played = 0;
      int octaves = 0;
      if (n.key < 0 || n.key > 127 || !resolve_note(o_.motors[m], static_cast<uint8_t>(n.key), &played, &octaves))
        continue;
      any_range = true;
      const Slot s = slot(m, n.on_s);
      if (s.conflict >= 0) {
        // Nearly done and of the same rank or lower: it may give way.
        const PlannedNote &c = plan_.notes[static_cast<size_t>(s.conflict)];
        const double done = n.on_s - c.on_s;
        if (ranks_[static_cast<size_t>(s.conflict)] >= rank && done >= kStealShare * (c.off_s - c.on_s) &&
            done >= o_.min_note_s && c.off_s < steal_end) {
          steal = static_cast<long>(m), steal_end = c.off_s, steal_until = s.next_on;
          steal_played = played;
        }
        continue;
      }
      if (s.next_on < n.off_s - kEps) {
        if (s.next_on - n.on_s > part_until - n.on_s || part < 0)
          part = static_cast<long>(m), part_until = s.next_on, part_played = played;
        continue;
      }
      // Fewest octaves folded; then a motor whose neighbour is this line, then one free of
      // other lines, then one with other lines near, then one that would have to strike this
      // pitch again; nearest in pitch; idle longest.
      int cls = 1;
      double distance = 0;
      for (long nb : {s.prev, s.next}) {
        if (nb < 0) continue;
        const PlannedNote &p = plan_.notes[static_cast<size_t>(nb)];
        if (lines_[static_cast<size_t>(nb)] == line) {
          // The same pitch again right after: another motor strikes it without the gap one
          // motor needs (kRestrikeGapS), when there is one.
          const bool restrike = p.pitch == played + o_.motors[m].tuning_cents / 100.0 &&
                                std::max(n.on_s - p.off_s, p.on_s - n.off_s) < kRestrikeGapS;
          cls = restrike ? 3 : 0;
          distance = std::fabs(keys_[static_cast<size_t>(nb)] - n.key);
          break;
        }
        if (std::max(n.on_s - p.off_s, p.on_s - n.off_s) < kLineGapS) cls = 2;
      }
      const double idle = s.prev >= 0 ? n.on_s - plan_.notes[static_cast<size_t>(s.prev)].off_s : kInf;
      const std::tuple<int, int, double, double> score{std::abs(octaves), cls, distance, -idle};
      if (best < 0 || score < best_score)
        best = static_cast<long>(m), best_score = score, best_until = n.off_s, best_played = played;
    }
    if (!any_range) return unplayed(n, Unplayed::kOutOfRange);
    // A doubling takes a free motor or none: it never cuts another note short.
    if (best < 0 && doubling) {
      extend(n);
      return unplayed(n, Unplayed::kDoubled);
    }
    const bool outer = n.role != Role::kInner || n.named >= 0 || n.top_s + n.bottom_s > 0;
    const double length = n.off_s - n.on_s;
    if (best < 0 && steal >= 0 && steal_until - n.on_s > part_until - n.on_s - kEps) {
      // Cut the note that is nearly done; this one takes the motor up to the next note there.
      const Slot s = slot(static_cast<size_t>(steal), n.on_s);
      plan_.notes[static_cast<size_t>(s.conflict)].off_s = n.on_s;
      ++plan_.shortened;
      best = steal, best_until = std::min(n.off_s, steal_until), best_played = steal_played;
    }
    if (best < 0 && part >= 0 && part_until - n.on_s >= o_.min_note_s &&
        (outer || part_until - n.on_s >= kInnerPartShare * length))
      best = part, best_until = part_until, best_played = part_played;
    if (best < 0) return unplayed(n, Unplayed::kNoMotor);
    if (best_until < n.off_s - kEps) ++plan_.shortened;
    add(static_cast<size_t>(best), n, best_until, best_played, n.key, line, rank);
  }

  // A motor's time around an instant: the note sounding there (conflict), the one before and the
  // one after, and when the next one starts.
  struct Slot {
    long conflict = -1, prev = -1, next = -1;
    double next_on = kInf;
  };

  // Called from: place_now, extend.
  Slot slot(size_t m, double on) const {
    Slot s;
    const auto &b = busy_[m];
    auto it = b.lower_bound(on - kEps);
    if (it != b.end()) {
      if (plan_.notes[it->second].on_s <= on + kEps) {
        s.conflict = static_cast<long>(it->second);
        return s;
      }
      s.next = static_cast<long>(it->second);
      s.next_on = plan_.notes[it->second].on_s;
    }
    if (it != b.begin()) {
      s.prev = static_cast<long>(std::prev(it)->second);
      if (plan_.notes[static_cast<size_t>(s.prev)].off_s > on + kEps) s.conflict = s.prev;
    }
    return s;
  }

  // The line a note belongs to, for keeping it on its motor: a named line, the melody, the
  // bass, or an inner voice's track and channel. Called from: place_now.
  static int line_of(const ArrangedNote &n) {
    if (n.named >= 0) return -4 - n.named;
    if (n.role == Role::kMelody) return -1;
    if (n.role == Role::kBass) return -2;
    return n.track * 16 + n.channel;
  }

  // True when a note already placed sounds n's pitch class within an octave over n's time,
  // and n adds nothing to it: the same role, or n an inner voice. Called from: place, place_now.
  bool doubled(const ArrangedNote &n) const {
    const auto &pc = by_class_[static_cast<size_t>(((n.key % 12) + 12) % 12)];
    const double quarter = 0.25 * (n.off_s - n.on_s);
    const double early = std::min(kDoublingEarlyS, quarter), late = std::min(kDoublingLateS, quarter);
    auto it = pc.upper_bound(n.on_s + late);
    for (int looked = 0; it != pc.begin() && looked < 64; ++looked) {
      --it;
      const size_t i = it->second;
      const PlannedNote &p = plan_.notes[i];
      if (p.off_s >= n.off_s - early && p.on_s >= n.on_s - early && std::abs(keys_[i] - n.key) <= 12 &&
          (p.role == n.role || n.role == Role::kInner) && n.named < 0)
        return true;
    }
    return false;
  }

  // When a placed note of n's pitch class within an octave (and a role n adds nothing to) still
  // sounds after n's start and ends before n does, on a motor free until n's end: holds it on
  // to n's end (unless only asked: extends) and returns true (n is heard, without an attack of
  // its own). Called from: place, place_now.
  bool extends(const ArrangedNote &n) { return extend(n, false); }
  bool extend(const ArrangedNote &n, bool apply = true) {
    if (n.named >= 0) return false;
    const auto &pc = by_class_[static_cast<size_t>(((n.key % 12) + 12) % 12)];
    const double slack = std::min(kDoublingEarlyS, 0.25 * (n.off_s - n.on_s));
    auto it = pc.upper_bound(n.on_s + std::min(kDoublingLateS, slack));
    for (int looked = 0; it != pc.begin() && looked < 64; ++looked) {
      --it;
      const size_t i = it->second;
      PlannedNote &p = plan_.notes[i];
      if (p.off_s <= n.on_s + kDoublingLateS || p.off_s >= n.off_s - slack || std::abs(keys_[i] - n.key) > 12 ||
          !(p.role == n.role || n.role == Role::kInner))
        continue;
      const Slot s = slot(p.motor, p.off_s);
      if (s.conflict >= 0 && s.conflict != static_cast<long>(i)) continue;
      if (s.next_on < n.off_s - slack) continue;
      if (apply) p.off_s = std::min(n.off_s, s.next_on);
      return true;
    }
    return false;
  }

  // Adds n on motor m until off, played as `played` for the wanted note. Called from: place,
  // place_drums.
  void add(size_t m, const ArrangedNote &n, double off, uint8_t played, int wanted, int line, int rank) {
    const size_t i = plan_.notes.size();
    const double pitch = played + o_.motors[m].tuning_cents / 100.0;
    const int octaves = (played - (wanted + o_.motors[m].transpose)) / 12;
    plan_.notes.push_back({n.on_s, off, static_cast<uint8_t>(m), pitch, n.song_index, n.role, static_cast<int8_t>(octaves)});
    busy_[m][n.on_s] = i;
    keys_.push_back(n.key);
    lines_.push_back(line);
    ranks_.push_back(rank);
    if (n.role != Role::kPercussion) by_class_[static_cast<size_t>(((n.key % 12) + 12) % 12)].emplace(n.on_s, i);
  }

  const PlanOptions &o_;
  Plan &plan_;
  std::vector<std::map<double, size_t>> busy_;  // per motor: its notes by start -> index in plan_.notes
  std::vector<int> keys_, lines_, ranks_;        // per placed note
  std::multimap<double, size_t> by_class_[12];   // per pitch class: placed notes by start
  std::vector<std::pair<const ArrangedNote *, int>> doublings_;  // left for place_doublings, with rank
};

}  // namespace

const char *unplayed_reason(Unplayed why) {
  switch (why) {
    case Unplayed::kNoMotor: return "every motor busy";
    case Unplayed::kTooShort: return "too short";
    case Unplayed::kOutOfRange: return "no motor can play its pitch";
    case Unplayed::kPercussion: return "percussion (--drums MOTOR plays it)";
    case Unplayed::kDoubled: return "doubles a note already sounding";
    case Unplayed::kNotKept: return "role not kept (--keep)";
    case Unplayed::kDrumTogether: return "another drum hit at the same time";
  }
  return "?";
}

const char *role_name(Role role) {
  switch (role) {
    case Role::kMelody: return "melody";
    case Role::kBass: return "bass";
    case Role::kInner: return "inner";
    case Role::kPercussion: return "drums";
  }
  return "?";
}

bool note_selected(const SongNote &n, const PlanOptions &o) {
  return (o.tracks.empty() || listed(o.tracks, n.track)) && (o.channels.empty() || listed(o.channels, n.channel)) &&
         !listed(o.mute_tracks, n.track) && !listed(o.mute_channels, n.channel) &&
         n.onset_s + n.duration_s > o.start_s + kEps;
}

Plan plan_song(const Song &song, const PlanOptions &o) {
  if (o.motors.empty()) throw std::invalid_argument("no motor to play the song");
  if (!(o.tempo_scale > 0) || !std::isfinite(o.tempo_scale))
    throw std::invalid_argument("tempo scale must be above 0");
  if (!(o.start_s >= 0)) throw std::invalid_argument("start position must be 0 or later");
  if (o.drum_motor >= static_cast<int>(o.motors.size()))
    throw std::invalid_argument("drum motor " + std::to_string(o.drum_motor) + ": the song has motors 0-" +
                                std::to_string(o.motors.size() - 1));
  if (o.drum_motor >= 0 && o.motors.size() < 2)
    throw std::invalid_argument("a drum motor needs another motor for the pitches");
  Plan plan;
  plan.duration_s = std::max(0.0, (song.duration_s - o.start_s) / o.tempo_scale);
  Placer placer(o, plan);
  std::vector<ArrangedNote> notes;
  for (uint32_t i = 0; i < song.notes.size(); ++i) {
    const SongNote &n = song.notes[i];
    if (!note_selected(n, o)) continue;
    ++plan.selected;
    const double end = n.onset_s + n.duration_s;
    ArrangedNote a;
    a.song_index = i;
    a.on_s = (std::max(n.onset_s, o.start_s) - o.start_s) / o.tempo_scale;
    a.off_s = (end - o.start_s) / o.tempo_scale;
    a.key = static_cast<int>(n.midi_note) + (n.percussion ? 0 : o.transpose);
    a.track = n.track;
    a.channel = n.channel;
    if (n.percussion) {
      a.role = Role::kPercussion;
      if (o.drum_motor < 0) placer.unplayed(a, Unplayed::kPercussion);
      else notes.push_back(a);
      continue;
    }
    if (a.off_s - a.on_s < o.min_note_s || !(a.off_s > a.on_s)) {
      placer.unplayed(a, Unplayed::kTooShort);
      continue;
    }
    notes.push_back(a);
  }
  const std::vector<uint32_t> order = arrange_notes(notes, song, o);
  for (size_t r = 0; r < order.size(); ++r) {
    const ArrangedNote &n = notes[order[r]];
    if (!o.keep.empty() && n.named < 0 && std::find(o.keep.begin(), o.keep.end(), n.role) == o.keep.end())
      placer.unplayed(n, Unplayed::kNotKept);
    else
      placer.place(n, n.named >= 0 ? n.named : static_cast<int>(o.voices.size()) + static_cast<int>(n.role));
  }
  placer.place_doublings();
  if (o.drum_motor >= 0) {
    std::vector<const ArrangedNote *> hits;
    for (const ArrangedNote &n : notes)
      if (n.role == Role::kPercussion) hits.push_back(&n);
    placer.place_drums(hits, song);
  }
  // The same pitch again on a motor right after its last note: leave a gap so it strikes again.
  std::vector<size_t> by_motor(plan.notes.size());
  for (size_t i = 0; i < by_motor.size(); ++i) by_motor[i] = i;
  std::sort(by_motor.begin(), by_motor.end(), [&](size_t a, size_t b) {
    const PlannedNote &x = plan.notes[a], &y = plan.notes[b];
    return x.motor != y.motor ? x.motor < y.motor : x.on_s < y.on_s;
  });
  for (size_t k = 1; k < by_motor.size(); ++k) {
    PlannedNote &prev = plan.notes[by_motor[k - 1]];
    const PlannedNote &next = plan.notes[by_motor[k]];
    if (prev.motor == next.motor && std::fabs(prev.pitch - next.pitch) < 0.5 && next.on_s - prev.off_s < kRestrikeGapS)
      prev.off_s = std::max(prev.on_s + 0.5 * (next.on_s - prev.on_s), next.on_s - kRestrikeGapS);
  }
  std::sort(plan.notes.begin(), plan.notes.end(), [](const PlannedNote &a, const PlannedNote &b) {
    return a.on_s != b.on_s ? a.on_s < b.on_s : a.song_index < b.song_index;
  });
  std::sort(plan.unplayed.begin(), plan.unplayed.end(),
            [](const UnplayedNote &a, const UnplayedNote &b) { return a.song_index < b.song_index; });
  return plan;
}

std::vector<PlanEvent> plan_events(const Plan &plan) {
  std::vector<PlanEvent> ev;
  ev.reserve(plan.notes.size() * 2);
  // Times to 0.1 us: a note's end and the next one's start, computed from different sums,
  // may differ in the last bits of a double and must still meet.
  auto q = [](double t) { return std::round(t * 1e7) / 1e7; };
  for (const PlannedNote &n : plan.notes) {
    ev.push_back({q(n.on_s), n.motor, false, n.pitch});
    ev.push_back({q(n.off_s), n.motor, true, 0});
  }
  // By time, motor; at one time and motor a silence goes before a note, so that dropping it
  // below leaves the note.
  std::stable_sort(ev.begin(), ev.end(), [](const PlanEvent &a, const PlanEvent &b) {
    if (a.time_s != b.time_s) return a.time_s < b.time_s;
    if (a.motor != b.motor) return a.motor < b.motor;
    return a.silent && !b.silent;
  });
  std::vector<PlanEvent> out;
  out.reserve(ev.size());
  for (size_t i = 0; i < ev.size(); ++i) {
    const PlanEvent &e = ev[i];
    if (e.silent && i + 1 < ev.size() && ev[i + 1].motor == e.motor && !ev[i + 1].silent &&
        ev[i + 1].time_s == e.time_s)
      continue;
    out.push_back(e);
  }
  return out;
}

}  // namespace stepchoir

// gcode.cpp: the G-code planner: voices -> segments -> moves that bounce at the borders.
// Pure: no I/O.
#include "song/gcode.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "core/pitch.h"
#include "song/corexy_head.h"
#include "song/delta_head.h"

namespace stepchoir {

namespace {

// Two score times closer than this are one instant (MIDI tempo maps leave rounding dust), s.
constexpr double kSameTimeS = 1e-7;
// A carriage this close to a border is at it, mm (far below the 1e-5 mm the G-code writes).
constexpr double kAtBorderMm = 1e-9;

// One voice's line, one note at a time: the highest sounding note wins.
struct Piece {
  double t0, t1;
  int midi_note;  // -1: silent
  bool onset;     // a note (re)starts at t0
};

// Reduces a voice's notes (sorted by onset) to a line of pieces; counts notes that never sound.
// Called by plan_gcode.
std::vector<Piece> voice_line(const std::vector<const SongNote *> &notes, size_t &hidden) {
  std::vector<double> times;
  for (const auto *n : notes) times.push_back(n->onset_s), times.push_back(n->onset_s + n->duration_s);
  std::sort(times.begin(), times.end());
  std::vector<double> cuts;
  for (double t : times)
    if (cuts.empty() || t - cuts.back() > kSameTimeS) cuts.push_back(t);
  std::vector<Piece> line;
  std::set<std::pair<int, size_t>> sounding;  // (note, index): the highest is the last
  std::vector<bool> heard(notes.size(), false);
  size_t next = 0, prev_source = SIZE_MAX;
  for (size_t c = 0; c + 1 < cuts.size(); ++c) {
    const double t0 = cuts[c], t1 = cuts[c + 1];
    while (next < notes.size() && notes[next]->onset_s <= t0 + kSameTimeS) {
      sounding.insert({notes[next]->midi_note, next});
      ++next;
    }
    for (auto it = sounding.begin(); it != sounding.end();) {
      const SongNote *n = notes[it->second];
      it = n->onset_s + n->duration_s <= t0 + kSameTimeS ? sounding.erase(it) : std::next(it);
    }
    if (sounding.empty()) {
      line.push_back({t0, t1, -1, false});
      prev_source = SIZE_MAX;
      continue;
    }
    const size_t source = sounding.rbegin()->second;
    heard[source] = true;
    line.push_back({t0, t1, notes[source]->midi_note, source != prev_source});
    prev_source = source;
  }
  hidden = static_cast<size_t>(std::count(heard.begin(), heard.end(), false));
  return line;
}

}  // namespace

std::vector<Voice> voices_of(const Song &song) {
  std::map<std::pair<uint16_t, uint8_t>, size_t> counts;
  for (const auto &n : song.notes) ++counts[{n.track, n.channel}];
  std::vector<Voice> out;
  for (const auto &[key, count] : counts) out.push_back({key.first, key.second, count});
  return out;
}

std::string note_name(int midi_note) {
  static const char *names[12] = {"C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"};
  return std::string(names[midi_note % 12]) + std::to_string(midi_note / 12 - 1);
}

GcodePlan plan_gcode(const Song &song, const Printer &printer, const GcodeOptions &options) {
  if (!(options.steps_per_cycle > 0) || options.steps_per_cycle > 64)
    throw GcodeError("steps per cycle must be above 0 and at most 64");
  GcodePlan plan;
  if (options.extruder && !(printer.axes[kExtruderAxis].steps_per_mm > 0))
    throw GcodeError("printer " + printer.name + " has no E steps/mm; give them as --steps-per-mm X,Y,Z,E");
  const size_t axes = options.extruder ? kGcodeAxes : kCartesianAxes;
  const std::string axis_list = options.extruder ? "X, Y, Z, E" : "X, Y, Z";
  plan.axis_count = axes;
  const std::vector<Voice> voices = voices_of(song);
  std::vector<size_t> chosen = options.voice_of_axis;
  if (chosen.empty()) {
    if (voices.size() > axes) {
      std::string list;
      for (size_t v = 0; v < voices.size(); ++v)
        list += "\n  " + std::to_string(v) + ": track " + std::to_string(voices[v].track) + " channel " +
                std::to_string(voices[v].channel) + " (" + std::to_string(voices[v].note_count) + " notes)";
      throw GcodeError("the song has " + std::to_string(voices.size()) + " voices and the printer " +
                       std::to_string(axes) + " axes; choose up to " + std::to_string(axes) +
                       " with --channels (e.g. --channels " + (options.extruder ? "0,1,2,3" : "0,1,2") + " for " +
                       axis_list + ")" + (options.extruder ? "" : " or add E with --extruder") + ":" + list);
    }
    for (size_t v = 0; v < voices.size(); ++v) chosen.push_back(v);
  }
  if (chosen.size() > axes)
    throw GcodeError("--channels names " + std::to_string(chosen.size()) + " voices; the printer has " +
                     std::to_string(axes) + " axes (" + axis_list + ")");
  for (size_t a = 0; a < chosen.size(); ++a) {
    if (chosen[a] >= voices.size())
      throw GcodeError("--channels: no voice " + std::to_string(chosen[a]) + "; the song has voices 0-" +
                       std::to_string(voices.size() - 1));
    for (size_t b = 0; b < a; ++b)
      if (chosen[b] == chosen[a]) throw GcodeError("--channels: voice " + std::to_string(chosen[a]) + " given twice");
    plan.axis_voice.push_back(voices[chosen[a]]);
  }
  const size_t used = chosen.size();

  // Each axis's line, folded into its feed limit if asked.
  std::vector<std::vector<Piece>> lines(used);
  for (size_t a = 0; a < used; ++a) {
    std::vector<const SongNote *> notes;
    for (const auto &n : song.notes)
      if (n.track == plan.axis_voice[a].track && n.channel == plan.axis_voice[a].channel) notes.push_back(&n);
    size_t hidden = 0;
    lines[a] = voice_line(notes, hidden);
    if (hidden)
      plan.warnings.push_back(std::string(1, kAxisNames[a]) + ": " + std::to_string(hidden) +
                              " notes of the voice are never heard: an axis plays one note at a time, the highest");
    const PrinterAxis &ax = printer.axes[a];
    if (ax.max_feed_mm_s <= 0) continue;
    std::map<int, size_t> too_fast;  // note -> count
    for (auto &p : lines[a]) {
      if (p.midi_note < 0) continue;
      const auto feed = [&](int note) { return note_hz(note) * options.steps_per_cycle / ax.steps_per_mm; };
      if (feed(p.midi_note) <= ax.max_feed_mm_s) continue;
      if (p.onset) ++too_fast[p.midi_note];
      if (options.fold_octaves)
        while (p.midi_note >= 12 && feed(p.midi_note) > ax.max_feed_mm_s) p.midi_note -= 12;
    }
    if (!too_fast.empty()) {
      std::string names;
      for (const auto &[note, count] : too_fast)
        names += (names.empty() ? "" : ", ") + note_name(note) + (count > 1 ? " (x" + std::to_string(count) + ")" : "");
      plan.warnings.push_back(std::string(1, kAxisNames[a]) + ": " + names + " need more than the max feed of " +
                              gcode_number(ax.max_feed_mm_s, 1) + " mm/s; " +
                              (options.fold_octaves ? "played octaves lower" : "kept (the printer will play them flat; --fold-octaves drops them octaves until they fit)"));
    }
  }

  // Segments: every instant where any axis's line changes.
  std::vector<double> cuts;
  for (const auto &l : lines)
    for (const auto &p : l) cuts.push_back(p.t0), cuts.push_back(p.t1);
  std::sort(cuts.begin(), cuts.end());
  std::vector<double> instants;
  for (double t : cuts)
    if (instants.empty() || t - instants.back() > kSameTimeS) instants.push_back(t);
  if (instants.empty() || instants.front() > kSameTimeS) instants.insert(instants.begin(), 0.0);
  plan.duration_s = instants.back();
  // Bound the output before making it: at most one move per segment plus one per border reached.
  double moves_bound = static_cast<double>(instants.size());
  for (size_t a = 0; a < used; ++a)
    for (const auto &p : lines[a])
      if (p.midi_note >= 0) {
        const PrinterAxis &ax = printer.axes[a];
        moves_bound += 1 + note_hz(p.midi_note) * options.steps_per_cycle / ax.steps_per_mm * (p.t1 - p.t0) /
                               (ax.max_mm - ax.min_mm);
      }
  if (moves_bound > kMaxGcodeMoves)
    throw GcodeError("the song would take some " + std::to_string(static_cast<long long>(moves_bound)) +
                     " moves (" + gcode_number(plan.duration_s, 0) + " s long), more than the " +
                     std::to_string(kMaxGcodeMoves) + " a G-code file is allowed here");

  double pos[kGcodeAxes], dir[kGcodeAxes] = {1, 1, 1, 1};
  for (size_t a = 0; a < kGcodeAxes; ++a) pos[a] = plan.start_mm[a] = (printer.axes[a].min_mm + printer.axes[a].max_mm) / 2;
  // CoreXY: motors A and B move the head together (CoreXYHead); Z and E bounce on their own.
  // Delta: the three towers' carriages hold the effector (DeltaHead), which starts in the middle
  // of the printable circle; E bounces on its own.
  const bool corexy = printer.kinematics == Kinematics::kCoreXY;
  const bool delta = printer.kinematics == Kinematics::kDelta;
  const size_t first_single = corexy ? 2 : delta ? 3 : 0;  // the first axis that bounces on its own
  if (delta) {
    check_delta(printer, "plan");
    pos[0] = pos[1] = plan.start_mm[0] = plan.start_mm[1] = 0;
  }
  std::unique_ptr<DeltaHead> tower;
  if (delta) {
    DeltaGeometry g;
    g.rod_mm = printer.delta_rod_mm;
    g.radius_mm = printer.delta_radius_mm;
    g.printable_mm = printer.delta_printable_mm;
    g.z_min_mm = printer.axes[2].min_mm;
    g.z_max_mm = printer.axes[2].max_mm;
    tower = std::make_unique<DeltaHead>(
        g, Vec3{pos[0], pos[1], pos[2]},
        Vec3{printer.axes[0].steps_per_mm, printer.axes[1].steps_per_mm, printer.axes[2].steps_per_mm});
  }
  // How far ahead a new note's or a reversal's directions are judged on a delta, s.
  constexpr double kDeltaHorizonS = 2.0;
  CoreXYHead head(pos[0], pos[1], printer.axes[0].min_mm, printer.axes[0].max_mm, printer.axes[1].min_mm,
                  printer.axes[1].max_mm, kAtBorderMm);
  auto stuck = [&](double t) {
    return GcodeError("the delta's effector is stuck at X" + gcode_number(pos[0], 3) + " Y" + gcode_number(pos[1], 3) +
                      " Z" + gcode_number(pos[2], 3) + " at " + gcode_number(t, 3) +
                      " s: no direction of the carriages keeps it inside");
  };
  auto cornered = [&](double t) {
    return GcodeError("the CoreXY head is cornered at X" + gcode_number(head.x(), 3) + " Y" + gcode_number(head.y(), 3) +
                      " at " + gcode_number(t, 3) + " s: no direction of A and B keeps it inside");
  };
  std::vector<size_t> cursor(used, 0);
  for (size_t s = 0; s + 1 < instants.size(); ++s) {
    GcodeSegment seg;
    seg.start_s = instants[s];
    seg.duration_s = instants[s + 1] - instants[s];
    double speed_mm_s[kGcodeAxes] = {0, 0, 0, 0};
    unsigned head_onsets = 0;  // CoreXY: A (bit 0) and B (bit 1) notes that start here
    for (size_t a = 0; a < used; ++a) {
      const auto &l = lines[a];
      size_t &c = cursor[a];
      while (c < l.size() && l[c].t1 <= seg.start_s + kSameTimeS) ++c;
      if (c == l.size() || l[c].t0 > seg.start_s + kSameTimeS || l[c].midi_note < 0) continue;
      const PrinterAxis &ax = printer.axes[a];
      seg.midi_note[a] = l[c].midi_note;
      speed_mm_s[a] = note_hz(l[c].midi_note) * options.steps_per_cycle / ax.steps_per_mm;
      // A note starting here heads for the border with more room ahead of it; a note that goes
      // on keeps its direction.
      if (l[c].onset && std::fabs(l[c].t0 - seg.start_s) <= kSameTimeS) {
        if (a < first_single)
          head_onsets |= 1u << a;  // the head's way is chosen below, for its motors together
        else
          dir[a] = ax.max_mm - pos[a] >= pos[a] - ax.min_mm ? 1 : -1;
      }
    }
    plan.segments.push_back(seg);
    if (corexy) {
      head.set_speed(0, speed_mm_s[0]);
      head.set_speed(1, speed_mm_s[1]);
      // New notes take the way that leaves the head the longest run to a side.
      if (head_onsets && !head.choose(head_onsets)) throw cornered(seg.start_s);
    }
    if (delta) {
      for (int t = 0; t < 3; ++t) tower->set_speed(t, speed_mm_s[t]);
      if (head_onsets && !tower->choose(head_onsets, kDeltaHorizonS)) throw stuck(seg.start_s);
    }
    const unsigned towers_moving = delta ? (speed_mm_s[0] > 0) | (speed_mm_s[1] > 0) << 1 | (speed_mm_s[2] > 0) << 2 : 0;
    // Firmware measures a move's feed on X, Y and Z only (E follows); a move of E alone on E.
    // On CoreXY the head's X and Y speeds change when one of A and B reverses: per piece.
    auto feed_mm_s = [&] {
      const double vx = corexy ? head.vx() : speed_mm_s[0], vy = corexy ? head.vy() : speed_mm_s[1];
      const double xyz = std::sqrt(vx * vx + vy * vy + speed_mm_s[2] * speed_mm_s[2]);
      return xyz > 0 ? xyz : speed_mm_s[kExtruderAxis];
    };
    if (std::all_of(speed_mm_s, speed_mm_s + kGcodeAxes, [](double v) { return v == 0; })) {
      GcodeStep d;
      d.dwell = true;
      d.duration_s = seg.duration_s;
      plan.steps.push_back(d);
      continue;
    }
    // Straight pieces until the segment ends; an axis reaching a border turns round, at the same
    // speed. Each piece ends a segment or brings an axis to a border, and an axis that turned
    // has its whole length ahead, so the loop ends after at most about duration x speed / length
    // pieces (bounded above).
    // An axis within kAtBorderMm of the border it heads for is there (rounding must not leave
    // it a room too small to ever cross).
    double left_s = seg.duration_s;
    while (left_s > 0) {
      double dt = left_s;
      if (corexy && head.moving()) {  // at a side: A, B or both reverse
        if (head.heading_out() && !head.choose(3)) throw cornered(seg.start_s + seg.duration_s - left_s);
        dt = std::min(dt, head.time_to_side());
      }
      if (delta && tower->moving()) {  // at the border: the carriages that keep it inside longest reverse
        // (looking at most kDeltaHorizonS ahead: a long note takes several pieces)
        double border_s = tower->time_to_border(std::min(left_s, kDeltaHorizonS));
        if (border_s < 1e-9) {
          tower->choose(towers_moving, kDeltaHorizonS);
          border_s = tower->time_to_border(std::min(left_s, kDeltaHorizonS));
          if (border_s < 1e-9) throw stuck(seg.start_s + seg.duration_s - left_s);
        }
        dt = std::min(dt, border_s);
      }
      for (size_t a = first_single; a < used; ++a) {
        if (speed_mm_s[a] == 0) continue;
        const PrinterAxis &ax = printer.axes[a];
        double room = dir[a] > 0 ? ax.max_mm - pos[a] : pos[a] - ax.min_mm;
        if (room <= kAtBorderMm) {
          pos[a] = dir[a] > 0 ? ax.max_mm : ax.min_mm;
          dir[a] = -dir[a];
          room = ax.max_mm - ax.min_mm;
        }
        dt = std::min(dt, room / speed_mm_s[a]);
      }
      const double feed = feed_mm_s();  // the speeds of this piece, before any axis turns at its end
      std::vector<DeltaMove> chords;  // a delta's effector: straight moves along its curve
      const double e_before = pos[kExtruderAxis];
      double chord_start[kCartesianAxes];
      std::copy(pos, pos + kCartesianAxes, chord_start);
      if (delta && tower->moving() && dt > 0) {
        tower->advance(dt, chords, kMaxGcodeMoves - std::min(kMaxGcodeMoves, plan.steps.size()));
        const Vec3 &e = tower->effector();
        std::copy(e.begin(), e.end(), pos);
      }
      if (corexy) {
        head.advance(dt);
        pos[0] = head.x();
        pos[1] = head.y();
      }
      for (size_t a = first_single; a < used; ++a) {
        if (speed_mm_s[a] == 0) continue;
        const PrinterAxis &ax = printer.axes[a];
        const double room = dir[a] > 0 ? ax.max_mm - pos[a] : pos[a] - ax.min_mm;
        if (room - speed_mm_s[a] * dt <= kAtBorderMm) {  // this axis reaches its border now
          pos[a] = dir[a] > 0 ? ax.max_mm : ax.min_mm;
          dir[a] = -dir[a];
        } else {
          pos[a] = std::clamp(pos[a] + dir[a] * speed_mm_s[a] * dt, ax.min_mm, ax.max_mm);
        }
      }
      if (dt <= 0) continue;  // an axis only turned round
      if (!chords.empty()) {  // E (if it sings) moves on evenly beside the effector
        const double e_end = pos[kExtruderAxis];
        double at_s = 0, from[kCartesianAxes];
        std::copy(chord_start, chord_start + kCartesianAxes, from);
        for (const DeltaMove &c : chords) {
          at_s += c.duration_s;
          GcodeStep m;
          std::copy(c.to.begin(), c.to.end(), m.pos_mm);
          m.pos_mm[kExtruderAxis] = e_before + (e_end - e_before) * std::min(1.0, at_s / dt);
          double len2 = 0;
          for (size_t a = 0; a < kCartesianAxes; ++a) len2 += (c.to[a] - from[a]) * (c.to[a] - from[a]);
          std::copy(c.to.begin(), c.to.end(), from);
          m.feed_mm_min = std::sqrt(len2) / c.duration_s * 60.0;
          m.duration_s = c.duration_s;
          plan.steps.push_back(m);
        }
        left_s = dt < left_s ? left_s - dt : 0;
        continue;
      }
      GcodeStep m;
      std::copy(pos, pos + kGcodeAxes, m.pos_mm);
      m.feed_mm_min = feed * 60.0;
      m.duration_s = dt;
      plan.steps.push_back(m);
      if (plan.steps.size() > kMaxGcodeMoves)
        throw GcodeError("the song takes more than the " + std::to_string(kMaxGcodeMoves) +
                         " moves a G-code file is allowed here (at " + gcode_number(seg.start_s, 3) + " s)");
      left_s = dt < left_s ? left_s - dt : 0;
    }
  }
  return plan;
}

}  // namespace stepchoir

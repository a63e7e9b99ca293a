// gcode.cpp: printer presets, the G-code planner (voices -> segments -> moves that bounce at the
// borders) and the G-code writer. Pure: no I/O.
#include "song/gcode.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>

#include "core/pitch.h"

namespace stepchoir {

extern const char kPrinterPresetsText[];  // host/data/printers.conf, generated at configure time

namespace {

// Two score times closer than this are one instant (MIDI tempo maps leave rounding dust), s.
constexpr double kSameTimeS = 1e-7;
// A carriage this close to a border is at it, mm (far below the 1e-5 mm the G-code writes).
constexpr double kAtBorderMm = 1e-9;

// Splits text at sep. Called by the field parsers.
std::vector<std::string_view> split(std::string_view text, char sep) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (;;) {
    const size_t at = text.find(sep, start);
    out.push_back(text.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start));
    if (at == std::string_view::npos) return out;
    start = at + 1;
  }
}

// A finite decimal number, the whole word (sign and fraction allowed). Called by the field
// parsers; throws GcodeError naming where and what.
double number(std::string_view w, const std::string &where, const char *what) {
  const std::string s(w);
  char *end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno || !std::isfinite(v) ||
      s.find_first_of("xXnNiI") != std::string::npos)
    throw GcodeError(where + ": expected a number for " + what + ", got '" + s + "'");
  return v;
}

// Comma-separated numbers, one per axis: X,Y,Z or X,Y,Z,E (E left as it is when not given).
// Called by make_printer.
void per_axis(std::string_view w, const std::string &where, const char *what, double out[kGcodeAxes]) {
  const auto parts = split(w, ',');
  if (parts.size() != kCartesianAxes && parts.size() != kGcodeAxes)
    throw GcodeError(where + ": expected " + what + " as X,Y,Z or X,Y,Z,E, got '" + std::string(w) + "'");
  for (size_t a = 0; a < parts.size(); ++a) out[a] = number(parts[a], where, what);
}

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

// Formats a number with fixed decimals. Called by write_gcode.
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

Printer make_printer(const std::string &name, std::string_view steps, std::string_view volume,
                             std::string_view max_feed, const std::string &where) {
  Printer p;
  p.name = name;
  double s[kGcodeAxes] = {0, 0, 0, 0}, f[kGcodeAxes] = {0, 0, 0, 0};
  per_axis(steps, where, "steps/mm", s);
  if (!max_feed.empty()) per_axis(max_feed, where, "max feed (mm/s)", f);
  const auto ranges = split(volume, ',');
  if (ranges.size() != kCartesianAxes)
    throw GcodeError(where + ": expected the volume as XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX, got '" + std::string(volume) + "'");
  PrinterAxis &e = p.axes[kExtruderAxis];
  e.steps_per_mm = s[kExtruderAxis];
  e.min_mm = -kExtruderTravelMm;
  e.max_mm = kExtruderTravelMm;
  e.max_feed_mm_s = f[kExtruderAxis];
  if (e.steps_per_mm < 0 || e.steps_per_mm > 1e6) throw GcodeError(where + ": E steps/mm must be 0 to 1000000");
  if (e.max_feed_mm_s < 0) throw GcodeError(where + ": E's max feed is negative");
  for (size_t a = 0; a < kCartesianAxes; ++a) {
    const auto ends = split(ranges[a], ':');
    if (ends.size() != 2)
      throw GcodeError(where + ": expected " + kAxisNames[a] + "'s range as MIN:MAX, got '" + std::string(ranges[a]) + "'");
    PrinterAxis &ax = p.axes[a];
    ax.steps_per_mm = s[a];
    ax.min_mm = number(ends[0], where, "the volume");
    ax.max_mm = number(ends[1], where, "the volume");
    ax.max_feed_mm_s = f[a];
    if (!(ax.steps_per_mm > 0) || ax.steps_per_mm > 1e6)
      throw GcodeError(where + ": " + kAxisNames[a] + " steps/mm must be above 0 and at most 1000000");
    if (!(ax.max_mm - ax.min_mm >= kMinAxisLengthMm))
      throw GcodeError(where + ": " + kAxisNames[a] + "'s range " + std::string(ranges[a]) + " is shorter than " +
                       fixed(kMinAxisLengthMm, 0) + " mm");
    if (ax.max_feed_mm_s < 0) throw GcodeError(where + ": " + kAxisNames[a] + "'s max feed is negative");
  }
  return p;
}

std::vector<Printer> parse_printers(std::string_view text, const std::string &source) {
  std::vector<Printer> out;
  int line_no = 0;
  for (std::string_view line : split(text, '\n')) {
    ++line_no;
    const auto w = split_words(line.substr(0, line.find('#')));
    if (w.empty()) continue;
    const std::string where = source + ":" + std::to_string(line_no);
    if (w.size() < 4)
      throw GcodeError(where + ": expected 'name steps/mm volume max-feed description', e.g. "
                               "'ender3 80,80,400 0:220,0:220,0:250 500,500,5 Ender-3'");
    Printer p = make_printer(std::string(w[0]), w[1], w[2], w[3], where);
    for (size_t i = 4; i < w.size(); ++i) p.description += (i > 4 ? " " : "") + std::string(w[i]);
    for (const auto &q : out)
      if (q.name == p.name) throw GcodeError(where + ": a second printer named '" + p.name + "'");
    out.push_back(std::move(p));
  }
  if (out.empty()) throw GcodeError(source + ": no printers");
  return out;
}

const std::vector<Printer> &builtin_printers() {
  static const std::vector<Printer> presets = parse_printers(kPrinterPresetsText, "printers.conf");
  return presets;
}

const Printer &find_printer(const std::vector<Printer> &printers, const std::string &name) {
  std::string names;
  for (const auto &p : printers) {
    if (p.name == name) return p;
    names += (names.empty() ? "" : ", ") + p.name;
  }
  throw GcodeError("no printer named '" + name + "'; known: " + names);
}

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
                              fixed(ax.max_feed_mm_s, 1) + " mm/s; " +
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
                     " moves (" + fixed(plan.duration_s, 0) + " s long), more than the " +
                     std::to_string(kMaxGcodeMoves) + " a G-code file is allowed here");

  double pos[kGcodeAxes], dir[kGcodeAxes] = {1, 1, 1, 1};
  for (size_t a = 0; a < kGcodeAxes; ++a) pos[a] = plan.start_mm[a] = (printer.axes[a].min_mm + printer.axes[a].max_mm) / 2;
  std::vector<size_t> cursor(used, 0);
  for (size_t s = 0; s + 1 < instants.size(); ++s) {
    GcodeSegment seg;
    seg.start_s = instants[s];
    seg.duration_s = instants[s + 1] - instants[s];
    double speed_mm_s[kGcodeAxes] = {0, 0, 0, 0};
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
      if (l[c].onset && std::fabs(l[c].t0 - seg.start_s) <= kSameTimeS)
        dir[a] = ax.max_mm - pos[a] >= pos[a] - ax.min_mm ? 1 : -1;
    }
    plan.segments.push_back(seg);
    // Firmware measures a move's feed on X, Y and Z only (E follows); a move of E alone on E.
    double combined = 0;
    for (size_t a = 0; a < kCartesianAxes; ++a) combined += speed_mm_s[a] * speed_mm_s[a];
    combined = combined > 0 ? std::sqrt(combined) : speed_mm_s[kExtruderAxis];
    if (combined == 0) {
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
      for (size_t a = 0; a < used; ++a) {
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
      for (size_t a = 0; a < used; ++a) {
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
      GcodeStep m;
      std::copy(pos, pos + kGcodeAxes, m.pos_mm);
      m.feed_mm_min = combined * 60.0;
      m.duration_s = dt;
      plan.steps.push_back(m);
      left_s = dt < left_s ? left_s - dt : 0;
    }
  }
  return plan;
}

std::string write_gcode(const GcodePlan &plan, const Printer &printer, const GcodeOptions &options,
                        const std::string &title) {
  const char *move = options.use_g1 ? "G1" : "G0";
  auto coords = [&](const double *p) {
    std::string s;
    for (size_t a = 0; a < plan.axis_count; ++a) s += std::string(" ") + kAxisNames[a] + fixed(p[a], 5);
    return s;
  };
  std::string out;
  std::string safe_title = title;  // a comment line: no control characters
  for (char &c : safe_title)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) c = '?';
  out += "; " + safe_title + "\n";
  out += "; stepchoir gcode: printer " + printer.name + " (" + printer.description + ")\n";
  out += "; steps/mm";
  for (size_t a = 0; a < plan.axis_count; ++a)
    out += std::string(" ") + kAxisNames[a] + fixed(printer.axes[a].steps_per_mm, 3);
  out += ", steps per cycle " + fixed(options.steps_per_cycle, 3) + ", length " + fixed(plan.duration_s, 3) + " s\n";
  for (size_t a = 0; a < plan.axis_voice.size(); ++a)
    out += std::string("; ") + kAxisNames[a] + " plays track " + std::to_string(plan.axis_voice[a].track) +
           " channel " + std::to_string(plan.axis_voice[a].channel) + "\n";
  for (const auto &w : plan.warnings) out += "; warning: " + w + "\n";
  out += "G21 ; millimetres\nG90 ; absolute positions\n";
  if (options.home) out += "G28 ; home every axis\n";
  // To the start: Z first (up, from a homed bed), then X and Y, each within its axis's max feed.
  auto travel_mm_min = [&](size_t a) {
    const double limit = printer.axes[a].max_feed_mm_s * 60.0;
    return limit > 0 ? std::min(kTravelFeedMmPerMin, limit) : kTravelFeedMmPerMin;
  };
  out += std::string(move) + " Z" + fixed(plan.start_mm[2], 5) + " F" + fixed(travel_mm_min(2), 3) +
         " ; to the middle of the volume\n";
  out += std::string(move) + " X" + fixed(plan.start_mm[0], 5) + " Y" + fixed(plan.start_mm[1], 5) + " F" +
         fixed(std::min(travel_mm_min(0), travel_mm_min(1)), 3) + "\n";
  if (plan.axis_count > kExtruderAxis)
    out += "M82 ; absolute extrusion\nG92 E0 ; the extruder starts at 0\n"
           "M302 P1 ; allow cold extrusion: E sings without filament (unload it first)\n";
  out += "M400 ; wait until there\n; song starts\n";
  double exact_s = 0, written_s = 0;  // dwell times are whole milliseconds; the rounding is carried
  for (const auto &st : plan.steps) {
    exact_s += st.duration_s;
    if (st.dwell) {
      const long ms = std::lround((exact_s - written_s) * 1000.0);
      if (ms > 0) out += "G4 P" + std::to_string(ms) + "\n";
      written_s += ms / 1000.0;
    } else {
      out += std::string(move) + coords(st.pos_mm) + " F" + fixed(st.feed_mm_min, 3) + "\n";
      written_s += st.duration_s;
    }
  }
  out += "; song ends\nM400 ; wait for the last note\n";
  if (plan.axis_count > kExtruderAxis) out += "M302 P0 ; cold extrusion prevented again\n";
  out += "M84 ; motors off\n";
  return out;
}

}  // namespace stepchoir

// gcode_reader.cpp: G-code text -> timed moves and motion limits.
#include "song/gcode_reader.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace stepchoir {

namespace {

// The number after a word's letter ("X12.5" -> 12.5, "ACCEL=3000" after the '='), or a
// GcodeError naming the line.
double value_of(const std::string &text, size_t line) {
  char *end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno || !std::isfinite(v))
    throw GcodeError("line " + std::to_string(line) + ": expected a number, got '" + text + "'");
  return v;
}

// Axis index of a letter (X Y Z E), or -1.
int axis_of(char c) {
  for (size_t a = 0; a < kGcodeAxes; ++a)
    if (c == kAxisNames[a]) return static_cast<int>(a);
  return -1;
}

}  // namespace

ReadGcode read_gcode(const std::string &text) {
  ReadGcode d;
  std::istringstream in(text);
  std::string line;
  double pos[kGcodeAxes] = {0, 0, 0, 0}, feed = 0, t = 0;
  MotionSettings settings;
  bool in_song = false;
  for (size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (line == "; song starts") {
      in_song = d.song_started = true;
      std::copy(pos, pos + kGcodeAxes, d.start);
      d.song_settings = settings;
    }
    if (line == "; song ends") d.song_ended = true, in_song = false;
    std::istringstream words(line.substr(0, line.find(';')));
    std::string w;
    if (!(words >> w)) continue;
    std::vector<std::string> args;
    for (std::string a; words >> a;) args.push_back(a);
    const bool after_song = d.song_ended;
    if (w == "G21") {
      d.millimetres = true;
    } else if (w == "G90") {
      d.absolute = true;
    } else if (w == "G28") {
      d.homed = true;
    } else if (w == "G92") {
      pos[kExtruderAxis] = 0;
    } else if (w == "M302") {
      d.cold_extrusion = !args.empty() && args[0] == "P1";
    } else if (w == "M501") {
      d.restores_settings = d.restores_settings || after_song;
    } else if (w == "M201" || w == "M205" || w == "M566") {
      for (const std::string &a : args) {
        if (a.size() < 2) continue;
        const double v = value_of(a.substr(1), line_no);
        const int axis = axis_of(a[0]);
        if (w == "M201" && axis >= 0) settings.max_accel_mm_s2[axis] = v;
        if (w == "M205" && axis >= 0) settings.jerk_mm_s[axis] = v;
        if (w == "M205" && a[0] == 'J') settings.junction_deviation_mm = v;
        if (w == "M566" && axis >= 0) settings.jerk_mm_s[axis] = v / 60.0;
      }
      d.restores_settings = d.restores_settings || after_song;
    } else if (w == "M204") {
      double p = -1, s = -1, tr = -1;
      for (const std::string &a : args) {
        if (a.size() < 2) continue;
        const double v = value_of(a.substr(1), line_no);
        if (a[0] == 'P') p = v;
        if (a[0] == 'S') s = v;
        if (a[0] == 'T') tr = v;
      }
      settings.accel_mm_s2 = tr > 0 ? tr : s > 0 ? s : p;  // moves without extrusion: travel
      d.restores_settings = d.restores_settings || after_song;
    } else if (w == "SET_VELOCITY_LIMIT") {
      for (const std::string &a : args) {
        const size_t eq = a.find('=');
        if (eq == std::string::npos) continue;
        const std::string key = a.substr(0, eq);
        const double v = value_of(a.substr(eq + 1), line_no);
        if (key == "ACCEL") settings.accel_mm_s2 = v;
        if (key == "SQUARE_CORNER_VELOCITY") settings.square_corner_mm_s = v;
        if (key == "MINIMUM_CRUISE_RATIO") settings.min_cruise_ratio = v;
      }
      d.restores_settings = d.restores_settings || after_song;
    } else if (w == "G4") {
      GcodeMove m;
      m.dwell = true;
      m.start_s = t;
      for (const std::string &a : args)
        if (a.size() > 1 && a[0] == 'P') m.duration_s = value_of(a.substr(1), line_no) / 1000.0;
      std::copy(pos, pos + kGcodeAxes, m.from);
      std::copy(pos, pos + kGcodeAxes, m.to);
      if (in_song) {
        t += m.duration_s;
        d.moves.push_back(m);
      }
    } else if (w == "G0" || w == "G1") {
      GcodeMove m;
      std::copy(pos, pos + kGcodeAxes, m.from);
      for (const std::string &a : args) {
        if (a.size() < 2) continue;
        const double v = value_of(a.substr(1), line_no);
        if (a[0] == 'F') feed = v;
        const int axis = axis_of(a[0]);
        if (axis >= 0) pos[axis] = v;
      }
      std::copy(pos, pos + kGcodeAxes, m.to);
      double dist = 0;
      for (size_t a = 0; a < kCartesianAxes; ++a) dist += (m.to[a] - m.from[a]) * (m.to[a] - m.from[a]);
      if (dist == 0) dist = (m.to[kExtruderAxis] - m.from[kExtruderAxis]) * (m.to[kExtruderAxis] - m.from[kExtruderAxis]);
      if (!(feed > 0)) throw GcodeError("line " + std::to_string(line_no) + ": a move without a feed (F)");
      m.feed_mm_min = feed;
      m.start_s = t;
      m.duration_s = std::sqrt(dist) / feed * 60.0;
      if (in_song) {
        t += m.duration_s;
        d.moves.push_back(m);
      }
    }
  }
  d.end_s = t;
  return d;
}

}  // namespace stepchoir

// gcode_check.h: decodes stepchoir's G-code back into moves and times, and checks it against the
// song it came from (step rates, segment times, volume, directions, last note). Used by the
// G-code unit tests and the end-to-end test of `stepchoir gcode`.
#ifndef STEPCHOIR_TESTS_GCODE_CHECK_H
#define STEPCHOIR_TESTS_GCODE_CHECK_H

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "pitch.h"
#include "song/gcode.h"
#include "song/song.h"

namespace gcheck {

using namespace stepchoir;

// One decoded line of the song part: a move or a dwell, with when it starts and how long it lasts.
struct Move {
  bool dwell = false;
  double from[kGcodeAxes] = {0, 0, 0}, to[kGcodeAxes] = {0, 0, 0};
  double feed_mm_min = 0, start_s = 0, duration_s = 0;
};

// What a G-code text says.
struct Decoded {
  bool homed = false, millimetres = false, absolute = false;
  double start[kGcodeAxes] = {0, 0, 0};  // position when the song starts
  std::vector<Move> moves;
  double end_s = 0;
};

// Decodes G0/G1 (X Y Z F, modal), G4 P, G21, G90, G28; the song is between "; song starts" and
// "; song ends". Called by the tests.
inline Decoded decode(const std::string &text) {
  Decoded d;
  std::istringstream in(text);
  std::string line;
  double pos[kGcodeAxes] = {0, 0, 0}, feed = 0, t = 0;
  bool in_song = false, ended = false;
  while (std::getline(in, line)) {
    if (line == "; song starts") {
      in_song = true;
      std::copy(pos, pos + kGcodeAxes, d.start);
    }
    if (line == "; song ends") ended = true, in_song = false;
    std::istringstream words(line.substr(0, line.find(';')));
    std::string w;
    if (!(words >> w)) continue;
    if (w == "G21") d.millimetres = true;
    else if (w == "G90") d.absolute = true;
    else if (w == "G28") d.homed = true;
    else if (w == "G4") {
      std::string p;
      words >> p;
      REQUIRE(p[0] == 'P');
      Move m;
      m.dwell = true;
      m.start_s = t;
      m.duration_s = std::stod(p.substr(1)) / 1000.0;
      std::copy(pos, pos + kGcodeAxes, m.from);
      std::copy(pos, pos + kGcodeAxes, m.to);
      t += m.duration_s;
      if (in_song) d.moves.push_back(m);
    } else if (w == "G0" || w == "G1") {
      Move m;
      std::copy(pos, pos + kGcodeAxes, m.from);
      while (words >> w) {
        const double v = std::stod(w.substr(1));
        if (w[0] == 'F') feed = v;
        for (size_t a = 0; a < kGcodeAxes; ++a)
          if (w[0] == kAxisNames[a]) pos[a] = v;
      }
      std::copy(pos, pos + kGcodeAxes, m.to);
      double dist = 0;
      for (size_t a = 0; a < kGcodeAxes; ++a) dist += (m.to[a] - m.from[a]) * (m.to[a] - m.from[a]);
      REQUIRE(feed > 0);
      m.feed_mm_min = feed;
      m.start_s = t;
      m.duration_s = std::sqrt(dist) / feed * 60.0;
      if (in_song) {
        t += m.duration_s;
        d.moves.push_back(m);
      }
    }
  }
  CHECK(ended);
  d.end_s = t;
  return d;
}

// The note a voice's axis should play at time t: the highest sounding note of the voice, folded
// by octaves under max_feed_mm_s when fold is set; -1 when silent. Called by check.
inline int expected_note(const Song &song, const Voice &v, double t, const PrinterAxis &ax, double spc, bool fold) {
  int best = -1;
  for (const auto &n : song.notes)
    if (n.track == v.track && n.channel == v.channel && n.onset_s <= t && t < n.onset_s + n.duration_s)
      best = std::max(best, int{n.midi_note});
  if (best >= 0 && fold && ax.max_feed_mm_s > 0)
    while (best >= 12 && note_hz(best) * spc / ax.steps_per_mm > ax.max_feed_mm_s) best -= 12;
  return best;
}

// Tolerances: dwells are written in whole milliseconds (the rounding is carried, so times never
// drift more than half of one); coordinates have 5 decimals.
constexpr double kTimeTolS = 1e-3;
constexpr double kRateTol = 1e-3;  // 0.1 %

// Checks decoded G-code against the song: every stretch of the score between two changes of any
// voice lasts what the score says and each axis steps at its note's rate within 0.1 % (silent
// axes do not move); every coordinate inside the volume; notes start toward the border with
// more room; the song ends with its last note. Called by the tests.
inline void check(const Decoded &d, const Song &song, const Printer &printer, const std::vector<Voice> &axis_voice,
                  double spc, bool fold = false) {
  std::vector<double> times;
  for (const auto &n : song.notes)
    for (const auto &v : axis_voice)
      if (n.track == v.track && n.channel == v.channel) times.push_back(n.onset_s), times.push_back(n.onset_s + n.duration_s);
  times.push_back(0);
  std::sort(times.begin(), times.end());
  std::vector<double> cuts;
  for (double t : times)
    if (cuts.empty() || t - cuts.back() > 1e-6) cuts.push_back(t);
  REQUIRE(cuts.size() >= 2);
  // The song ends with its last note: the G-code lasts until the last note of the chosen voices ends.
  CHECK(d.end_s == Approx(cuts.back()).margin(kTimeTolS));
  for (const auto &m : d.moves)
    for (size_t a = 0; a < kGcodeAxes; ++a) {
      CHECK(m.to[a] >= printer.axes[a].min_mm - 1e-9);
      CHECK(m.to[a] <= printer.axes[a].max_mm + 1e-9);
    }
  size_t i = 0;
  for (size_t s = 0; s + 1 < cuts.size(); ++s) {
    const double t0 = cuts[s], t1 = cuts[s + 1], mid = (t0 + t1) / 2;
    INFO("segment " << s << " from " << t0 << " s to " << t1 << " s");
    REQUIRE(i < d.moves.size());
    CHECK(d.moves[i].start_s == Approx(t0).margin(kTimeTolS));
    double travelled[kGcodeAxes] = {0, 0, 0}, duration = 0;
    const size_t first = i;
    while (i < d.moves.size() && d.moves[i].start_s < t1 - kTimeTolS) {
      for (size_t a = 0; a < kGcodeAxes; ++a) travelled[a] += std::fabs(d.moves[i].to[a] - d.moves[i].from[a]);
      duration += d.moves[i].duration_s;
      ++i;
    }
    CHECK(duration == Approx(t1 - t0).margin(kTimeTolS));
    for (size_t a = 0; a < kGcodeAxes; ++a) {
      INFO("axis " << kAxisNames[a]);
      const PrinterAxis &ax = printer.axes[a];
      const int note = a < axis_voice.size() ? expected_note(song, axis_voice[a], mid, ax, spc, fold) : -1;
      if (note < 0) {
        CHECK(travelled[a] == 0);
        continue;
      }
      const double want_steps_s = note_hz(note) * spc;
      const double got_steps_s = travelled[a] * ax.steps_per_mm / duration;
      INFO("note " << note_name(note) << ": " << want_steps_s << " steps/s wanted, " << got_steps_s << " decoded");
      CHECK(std::fabs(got_steps_s / want_steps_s - 1) <= kRateTol);
      // A note starting here (the voice's top note has its onset here) heads for the border with
      // more room.
      const int top = expected_note(song, axis_voice[a], mid, ax, spc, false);
      bool starts = false;
      for (const auto &n : song.notes)
        starts = starts || (n.track == axis_voice[a].track && n.channel == axis_voice[a].channel &&
                            n.midi_note == top && std::fabs(n.onset_s - t0) < 1e-6);
      const double p = d.moves[first].from[a], up = ax.max_mm - p, down = p - ax.min_mm;
      if (starts && std::fabs(up - down) > 1e-3) {
        const double step = d.moves[first].to[a] - d.moves[first].from[a];
        CHECK((up > down ? step > 0 : step < 0));
      }
    }
  }
  CHECK(i == d.moves.size());
}

}  // namespace gcheck

#endif  // STEPCHOIR_TESTS_GCODE_CHECK_H

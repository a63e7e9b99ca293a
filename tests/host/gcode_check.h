// gcode_check.h: checks stepchoir's G-code, read back into moves and times, against the
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

#include "core/pitch.h"
#include "song/gcode.h"
#include "song/gcode_reader.h"
#include "song/song.h"

namespace gcheck {

using namespace stepchoir;

// A decoded line of the song part, and what a G-code text says (song/gcode_reader.h).
using Move = GcodeMove;
using Decoded = ReadGcode;

// Reads the G-code (read_gcode) and checks that the song part ends. Called by the tests.
inline Decoded decode(const std::string &text) {
  Decoded d = read_gcode(text);
  CHECK(d.song_started);
  CHECK(d.song_ended);
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

// Tolerances: dwells are written in whole milliseconds (the rounding is carried, so a time is
// never more than half of one off, and a stretch between two times at most one), plus float dust;
// coordinates have 5 decimals.
constexpr double kTimeTolS = 1e-3 + 1e-9;
constexpr double kRateTol = 1e-3;  // 0.1 %

// What is wrong with decoded G-code against the song (empty: nothing): every stretch of the
// score between two changes of any voice must last what the score says and each axis must step
// at its note's rate within 0.1 % (silent axes do not move); every coordinate inside the volume;
// notes start toward the border with more room; the song ends with its last note. Called by
// check and the test that shows it finds broken G-code.
inline std::vector<std::string> problems(const Decoded &d, const Song &song, const Printer &printer,
                                         const std::vector<Voice> &axis_voice, double spc, bool fold = false) {
  std::vector<std::string> out;
  auto expect = [&](bool ok, const std::string &what) {
    if (!ok) out.push_back(what);
  };
  std::vector<double> times;
  for (const auto &n : song.notes)
    for (const auto &v : axis_voice)
      if (n.track == v.track && n.channel == v.channel) times.push_back(n.onset_s), times.push_back(n.onset_s + n.duration_s);
  times.push_back(0);
  std::sort(times.begin(), times.end());
  std::vector<double> cuts;
  for (double t : times)
    if (cuts.empty() || t - cuts.back() > 1e-6) cuts.push_back(t);
  // The song ends with its last note: the G-code lasts until the last note of the chosen voices ends.
  expect(std::fabs(d.end_s - cuts.back()) <= kTimeTolS,
         "the G-code lasts " + std::to_string(d.end_s) + " s, the score " + std::to_string(cuts.back()) + " s");
  for (size_t k = 0; k < d.moves.size(); ++k)
    for (size_t a = 0; a < kGcodeAxes; ++a)
      expect(d.moves[k].to[a] >= printer.axes[a].min_mm - 1e-9 && d.moves[k].to[a] <= printer.axes[a].max_mm + 1e-9,
             "move " + std::to_string(k) + ": " + kAxisNames[a] + std::to_string(d.moves[k].to[a]) + " outside the volume");
  size_t i = 0;
  for (size_t s = 0; s + 1 < cuts.size(); ++s) {
    const double t0 = cuts[s], t1 = cuts[s + 1], mid = (t0 + t1) / 2;
    const std::string where = "segment " + std::to_string(s) + " (" + std::to_string(t0) + " s to " + std::to_string(t1) + " s)";
    if (i >= d.moves.size()) {
      out.push_back(where + ": no G-code left");
      break;
    }
    expect(std::fabs(d.moves[i].start_s - t0) <= kTimeTolS,
           where + ": starts at " + std::to_string(d.moves[i].start_s) + " s in the G-code");
    // What each motor travelled, mm of its own coordinate: on CoreXY, A's is X + Y and B's X - Y.
    const bool corexy = printer.kinematics == Kinematics::kCoreXY;
    double travelled[kGcodeAxes] = {0, 0, 0}, duration = 0;
    const size_t first = i;
    // A move belongs to the stretch its middle falls in (a bounce may leave a move shorter
    // than the times' tolerance just before a stretch ends).
    while (i < d.moves.size() && d.moves[i].start_s + d.moves[i].duration_s / 2 < t1) {
      double delta[kGcodeAxes];
      for (size_t a = 0; a < kGcodeAxes; ++a) delta[a] = d.moves[i].to[a] - d.moves[i].from[a];
      if (corexy) {
        const double x = delta[0], y = delta[1];
        delta[0] = x + y;
        delta[1] = x - y;
      }
      for (size_t a = 0; a < kGcodeAxes; ++a) travelled[a] += std::fabs(delta[a]);
      duration += d.moves[i].duration_s;
      ++i;
    }
    // Written coordinates have 5 decimals: a silent CoreXY motor may seem to move by their rounding.
    const double still_mm = corexy ? 2e-5 * static_cast<double>(i - first) : 0;
    expect(std::fabs(duration - (t1 - t0)) <= kTimeTolS, where + ": lasts " + std::to_string(duration) + " s");
    for (size_t a = 0; a < kGcodeAxes; ++a) {
      const std::string axis = where + ", " + motor_name(printer.kinematics, a);
      const PrinterAxis &ax = printer.axes[a];
      const int note = a < axis_voice.size() ? expected_note(song, axis_voice[a], mid, ax, spc, fold) : -1;
      if (note < 0) {
        expect(travelled[a] <= still_mm, axis + ": silent, but moves " + std::to_string(travelled[a]) + " mm");
        continue;
      }
      const double want_steps_s = note_hz(note) * spc;
      const double got_steps_s = travelled[a] * ax.steps_per_mm / duration;
      // Coordinates have 5 decimals: each move's length may be off by 1e-5 mm (2e-5 on CoreXY's A and B).
      const double rounding_mm = (corexy && a < 2 ? 2e-5 : 1e-5) * static_cast<double>(i - first);
      expect(std::fabs(got_steps_s - want_steps_s) <= kRateTol * want_steps_s + rounding_mm * ax.steps_per_mm / duration,
             axis + ": " + note_name(note) + " wants " + std::to_string(want_steps_s) + " steps/s, the G-code makes " +
                 std::to_string(got_steps_s));
      // A note starting here (the voice's top note has its onset here) heads for the border with
      // more room.
      const int top = expected_note(song, axis_voice[a], mid, ax, spc, false);
      bool starts = false;
      for (const auto &n : song.notes)
        starts = starts || (n.track == axis_voice[a].track && n.channel == axis_voice[a].channel &&
                            n.midi_note == top && std::fabs(n.onset_s - t0) < 1e-6);
      const double p = d.moves[first].from[a], up = ax.max_mm - p, down = p - ax.min_mm;
      if (starts && std::fabs(up - down) > 1e-3 && !(corexy && a < 2)) {  // a CoreXY head: see corexy_head.h
        const double step = d.moves[first].to[a] - d.moves[first].from[a];
        expect(up > down ? step > 0 : step < 0, axis + ": the note starts toward the border with less room");
      }
    }
  }
  expect(i == d.moves.size(), std::to_string(d.moves.size() - i) + " G-code lines after the score's end");
  return out;
}

// Fails the current test with each problem of the G-code. Called by the tests.
inline void check(const Decoded &d, const Song &song, const Printer &printer, const std::vector<Voice> &axis_voice,
                  double spc, bool fold = false) {
  const auto found = problems(d, song, printer, axis_voice, spc, fold);
  for (const auto &p : found) FAIL_CHECK(p);
  CHECK(found.empty());
}

}  // namespace gcheck

#endif  // STEPCHOIR_TESTS_GCODE_CHECK_H

// gcode_check.h: checks stepchoir's G-code, read back into moves and times, against the
// song it came from (step rates, segment times, volume, directions, last note). Used by the
// G-code unit tests and the end-to-end test of `stepchoir gcode`.
#ifndef STEPCHOIR_TESTS_GCODE_CHECK_H
#define STEPCHOIR_TESTS_GCODE_CHECK_H

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>
#include <sstream>
#include <string>
#include <vector>

#include "core/pitch.h"
#include "song/gcode.h"
#include "song/delta_head.h"
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
constexpr double kDeltaRateTol = 5e-3;

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
  if (printer.kinematics == Kinematics::kDelta)
    for (size_t k = 0; k < d.moves.size(); ++k) {
      const double r = std::hypot(d.moves[k].to[0], d.moves[k].to[1]);
      expect(r <= printer.delta_printable_mm + 1e-4,
             "move " + std::to_string(k) + ": " + std::to_string(r) + " mm from the centre, outside the printable radius");
    }
  for (size_t k = 0; k < d.moves.size(); ++k)
    for (size_t a = 0; a < kGcodeAxes; ++a)
      expect(d.moves[k].to[a] >= printer.axes[a].min_mm - 1e-9 && d.moves[k].to[a] <= printer.axes[a].max_mm + 1e-9,
             "move " + std::to_string(k) + ": " + kAxisNames[a] + std::to_string(d.moves[k].to[a]) + " outside the volume");
  // Dwells are whole milliseconds, so the written times run up to half of one off the score's
  // after each dwell; a dwell ends where a stretch of the score starts, so the moves after it are
  // timed from there (what a move is then off by is the G-code's own error).
  std::vector<double> start(d.moves.size());
  double offset = 0;
  for (size_t k = 0; k < d.moves.size(); ++k) {
    if (k > 0 && d.moves[k - 1].dwell && !d.moves[k].dwell) {
      const auto near = std::lower_bound(cuts.begin(), cuts.end(), d.moves[k].start_s - kTimeTolS);
      if (near != cuts.end() && std::fabs(*near - d.moves[k].start_s) <= kTimeTolS) offset = *near - d.moves[k].start_s;
    }
    start[k] = d.moves[k].start_s + offset;
  }
  size_t i = 0;
  for (size_t s = 0; s + 1 < cuts.size(); ++s) {
    const double t0 = cuts[s], t1 = cuts[s + 1], mid = (t0 + t1) / 2;
    const std::string where = "segment " + std::to_string(s) + " (" + std::to_string(t0) + " s to " + std::to_string(t1) + " s)";
    if (i >= d.moves.size()) {
      out.push_back(where + ": no G-code left");
      break;
    }
    expect(std::fabs(start[i] - t0) <= kTimeTolS, where + ": starts at " + std::to_string(start[i]) + " s in the G-code");
    // What each motor travelled, mm of its own coordinate: on CoreXY, A's is X + Y and B's X - Y;
    // on a delta, each tower's carriage height (inverse kinematics of the move's ends).
    const bool corexy = printer.kinematics == Kinematics::kCoreXY;
    const bool delta = printer.kinematics == Kinematics::kDelta;
    DeltaGeometry geometry;
    geometry.rod_mm = printer.delta_rod_mm;
    geometry.radius_mm = printer.delta_radius_mm;
    double travelled[kGcodeAxes] = {0, 0, 0}, duration = 0;
    const size_t first = i;
    // A move belongs to the stretch its middle falls in (a bounce may leave a move shorter
    // than the times' tolerance just before a stretch ends).
    while (i < d.moves.size() && start[i] + d.moves[i].duration_s / 2 < t1) {
      double change[kGcodeAxes];
      for (size_t a = 0; a < kGcodeAxes; ++a) change[a] = d.moves[i].to[a] - d.moves[i].from[a];
      if (corexy) {
        const double x = change[0], y = change[1];
        change[0] = x + y;
        change[1] = x - y;
      }
      if (delta) {
        Vec3 h0, h1;
        const bool reach = delta_inverse(geometry, {d.moves[i].from[0], d.moves[i].from[1], d.moves[i].from[2]}, &h0) &&
                           delta_inverse(geometry, {d.moves[i].to[0], d.moves[i].to[1], d.moves[i].to[2]}, &h1);
        expect(reach, where + ": move " + std::to_string(i) + " out of the rods' reach");
        for (size_t a = 0; a < 3; ++a) change[a] = reach ? h1[a] - h0[a] : 0;
      }
      for (size_t a = 0; a < kGcodeAxes; ++a) travelled[a] += std::fabs(change[a]);
      duration += d.moves[i].duration_s;
      ++i;
    }
    // Written coordinates have 5 decimals: a silent CoreXY motor may seem to move by their rounding.
    const double still_mm = corexy || delta ? 4e-5 * static_cast<double>(i - first) : 0;
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
      const double rounding_mm = (corexy && a < 2 ? 2e-5 : delta && a < 3 ? 4e-5 : 1e-5) * static_cast<double>(i - first);
      // A delta's carriages follow the written straight moves within 0.5 %.
      const double rate_tol = delta && a < 3 ? kDeltaRateTol : kRateTol;
      expect(std::fabs(got_steps_s - want_steps_s) <= rate_tol * want_steps_s + rounding_mm * ax.steps_per_mm / duration,
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
      if (starts && std::fabs(up - down) > 1e-3 && !(corexy && a < 2) && !(delta && a < 3)) {  // heads: their own rules
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

// Songs and printers for the tests.

// A song from (voice, onset, duration, note) rows; voice is the track. Called by the tests.
inline Song song_of(const std::vector<std::tuple<int, double, double, int>> &rows) {
  Song s;
  for (const auto &[voice, onset, duration, note] : rows) {
    SongNote n;
    n.track = static_cast<uint16_t>(voice);
    n.onset_s = onset;
    n.duration_s = duration;
    n.midi_note = static_cast<uint8_t>(note);
    n.velocity = 100;
    s.notes.push_back(n);
    s.track_count = std::max<uint16_t>(s.track_count, static_cast<uint16_t>(voice + 1));
  }
  finish_song(s, 0);
  return s;
}

// A printer with the given X, Y, Z lengths from 0 and 80/80/400 steps/mm, no feed limit.
inline Printer box(double x, double y, double z) {
  return make_printer("box", "80,80,400",
                      "0:" + std::to_string(x) + ",0:" + std::to_string(y) + ",0:" + std::to_string(z), "", "test");
}

// Plans, writes, decodes and checks a song; returns the decoded G-code. Called by the tests.
inline Decoded round_trip(const Song &song, const Printer &printer, const GcodeOptions &o = {}) {
  const GcodePlan plan = plan_gcode(song, printer, o);
  const Decoded d = decode(write_gcode(plan, printer, o, "test"));
  check(d, song, printer, plan.axis_voice, o.steps_per_cycle, o.fold_octaves);
  return d;
}

// A song of `voices` voices of 30 notes or rests each, MIDI 40-84, some with a lower note under
// them (a chord: the higher note plays). Called by the generated-song tests.
inline Song random_song(std::mt19937 &rng, int voices) {
  std::vector<std::tuple<int, double, double, int>> rows;
  for (int v = 0; v < voices; ++v) {
    double t = 0;
    for (int k = 0; k < 30; ++k) {
      const double len = (1 + rng() % 8) / 16.0;
      if (rng() % 4 == 0) {  // a rest
        t += len;
        continue;
      }
      const int note = 40 + static_cast<int>(rng() % 45);
      rows.emplace_back(v, t, len, note);
      if (rng() % 6 == 0) rows.emplace_back(v, t, len / 2, note - 3);
      t += len;
    }
  }
  return song_of(rows);
}

}  // namespace gcheck

#endif  // STEPCHOIR_TESTS_GCODE_CHECK_H

// fuzz_plan.h: runs the G-code planner and writer on a song a fuzz target read, checking that
// every coordinate stays inside the volume.
#ifndef STEPCHOIR_TESTS_FUZZ_PLAN_H
#define STEPCHOIR_TESTS_FUZZ_PLAN_H

#include <cstdlib>

#include "song/gcode.h"
#include "song/song.h"

// Plans a read song on a small printer (so that bounces happen), with the extruder for some;
// aborts, for libFuzzer to
// report, when a move leaves the volume. Songs longer than ten minutes are skipped to keep each
// run fast. Called by the fuzz targets.
inline void fuzz_plan(const stepchoir::Song &song) {
  if (song.duration_s > 600) return;
  // Cartesian, CoreXY or (songs up to a minute) a small delta, by the song's note count.
  static const stepchoir::Printer box =
      stepchoir::make_printer("fuzz", "80,80,400,100", "0:10,-5:5,0:2", "200,200,5,25", "fuzz");
  static const stepchoir::Printer delta = [] {
    stepchoir::Printer p = stepchoir::make_printer("fuzz", "80,80,80,100", "-10:10,-10:10,100:104", "200,200,200,25", "fuzz");
    p.kinematics = stepchoir::Kinematics::kDelta;
    p.delta_rod_mm = 267;
    p.delta_radius_mm = 134;
    p.delta_printable_mm = 10;
    return p;
  }();
  const size_t kind = song.notes.size() % 3;
  if (kind == 2 && song.duration_s > 60) return;
  stepchoir::Printer printer = kind == 2 ? delta : box;
  if (kind == 1) printer.kinematics = stepchoir::Kinematics::kCoreXY;
  stepchoir::GcodeOptions options;
  options.fold_octaves = song.notes.size() % 2 == 0;
  options.extruder = song.notes.size() % 3 == 0;
  try {
    const stepchoir::GcodePlan plan = stepchoir::plan_gcode(song, printer, options);
    for (const auto &step : plan.steps) {
      for (size_t a = 0; a < stepchoir::kGcodeAxes; ++a)
        if (!step.dwell && (step.pos_mm[a] < printer.axes[a].min_mm || step.pos_mm[a] > printer.axes[a].max_mm))
          std::abort();
      if (kind == 2 && !step.dwell && step.pos_mm[0] * step.pos_mm[0] + step.pos_mm[1] * step.pos_mm[1] > 10.0001 * 10.0001)
        std::abort();
    }
    stepchoir::write_gcode(plan, printer, options, "fuzz");
  } catch (const stepchoir::GcodeError &) {
  }
}

#endif  // STEPCHOIR_TESTS_FUZZ_PLAN_H

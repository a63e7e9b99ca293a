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
  static const stepchoir::Printer printer =
      stepchoir::make_printer("fuzz", "80,80,400,100", "0:10,-5:5,0:2", "200,200,5,25", "fuzz");
  stepchoir::GcodeOptions options;
  options.fold_octaves = song.notes.size() % 2 == 0;
  options.extruder = song.notes.size() % 3 == 0;
  try {
    const stepchoir::GcodePlan plan = stepchoir::plan_gcode(song, printer, options);
    for (const auto &step : plan.steps)
      for (size_t a = 0; a < stepchoir::kGcodeAxes; ++a)
        if (!step.dwell && (step.pos_mm[a] < printer.axes[a].min_mm || step.pos_mm[a] > printer.axes[a].max_mm))
          std::abort();
    stepchoir::write_gcode(plan, printer, options, "fuzz");
  } catch (const stepchoir::GcodeError &) {
  }
}

#endif  // STEPCHOIR_TESTS_FUZZ_PLAN_H

// motion_model.h: a model of a printer firmware's motion planner, to measure how much of each
// note a printer plays at its pitch. A firmware does not run a G-code move at its feed from the
// first step: it accelerates from the speed the junction with the previous move allows, and
// slows for the next, so a note starts and ends flat. The model is the trapezoid planner that
// Marlin, Klipper and RepRapFirmware share (look-ahead over the moves, a constant acceleration,
// a speed at each junction), with each firmware's junction rule:
// - Marlin: junction deviation J: v^2 = a J sin(t/2) / (1 - sin(t/2)), t the angle between the
//   moves' directions (straight on: no limit; reversing: 0);
// - Klipper: the same with J = v_sc^2 (sqrt 2 - 1) / a from its square corner velocity v_sc, at
//   most the centripetal speed of half of the shorter move, and a minimum cruise ratio (a short
//   move's top speed leaves at least that share of it at cruise);
// - RepRapFirmware: a per-axis jerk (M566): the junction speed at which no axis's speed changes
//   by more than its jerk.
// Pure; called from: the G-code tests and tools/bench/gcode_motion_bench.cpp.
#ifndef STEPCHOIR_HOST_SONG_MOTION_MODEL_H
#define STEPCHOIR_HOST_SONG_MOTION_MODEL_H

#include "song/gcode.h"
#include "song/gcode_reader.h"
#include "song/song.h"

namespace stepchoir {

// A firmware's motion limits, as the model uses them (mm, s).
struct MotionLimits {
  Firmware firmware = Firmware::kMarlin;
  double accel_mm_s2 = 500;                               // moves without extrusion
  double max_accel_mm_s2[kGcodeAxes] = {0, 0, 0, 0};      // per axis, 0 = none
  double junction_deviation_mm = 0.08;                    // Marlin
  double square_corner_mm_s = 5;                          // Klipper
  double min_cruise_ratio = 0.5;                          // Klipper
  double jerk_mm_s[kGcodeAxes] = {10, 10, 0.4, 5};        // RepRapFirmware
};

// The limits a printer runs with by itself (its firmware's configuration as the preset gives
// it), or with the song header's settings (safe=true: what `stepchoir gcode` sets).
MotionLimits printer_limits(const Printer &printer, Firmware firmware, bool safe);

// `base` with the limits a G-code text sets before its song over it.
MotionLimits with_settings(MotionLimits base, const MotionSettings &settings);

// What the model found.
struct MotionReport {
  double note_s = 0;      // time the moves take with acceleration (dwells left out)
  double in_tune_s = 0;   // of it, time within the cents asked of the moves' written speeds
  double written_s = 0;   // the same moves at their written feeds
  size_t moves = 0;
  size_t moves_in_tune = 0;  // moves at least 90 % of whose time is in tune
  double share() const { return note_s > 0 ? in_tune_s / note_s : 1.0; }
};

// Plans the song's moves as the firmware would and measures the time within `cents` of each
// move's written speed (every motor of a move is off by the same ratio).
MotionReport model_motion(const ReadGcode &gcode, const MotionLimits &limits, double cents = 5.0);

// What the header's limits do for a song on a printer: its G-code written as `options` say
// (set_limits on) and with the printer's limits left alone, each read back and run through the
// model of options.flavor on the printer's own limits under what the G-code sets.
// Called from: the G-code tests, tools/bench/gcode_motion_bench.cpp.
struct HeaderEffect {
  MotionReport own, header;
};
HeaderEffect header_effect(const Song &song, const Printer &printer, GcodeOptions options);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_MOTION_MODEL_H

// gcode_reader.h: reads G-code of the kind `stepchoir gcode` writes back into timed moves and
// the motion limits its header sets, the way a printer's firmware would take them: the one
// reader for the tests' checks and the motion model (song/motion_model.h).
#ifndef STEPCHOIR_HOST_SONG_GCODE_READER_H
#define STEPCHOIR_HOST_SONG_GCODE_READER_H

#include <string>
#include <vector>

#include "song/gcode.h"

namespace stepchoir {

// One line of the song part: a move or a dwell, when it starts and how long it lasts at its
// feed (no acceleration).
struct GcodeMove {
  bool dwell = false;
  double from[kGcodeAxes] = {0, 0, 0, 0}, to[kGcodeAxes] = {0, 0, 0, 0};
  double feed_mm_min = 0, start_s = 0, duration_s = 0;
};

// Motion limits a G-code text sets; a negative value: not set.
struct MotionSettings {
  double accel_mm_s2 = -1;                            // M204 T (or S, P); SET_VELOCITY_LIMIT ACCEL
  double max_accel_mm_s2[kGcodeAxes] = {-1, -1, -1, -1};  // M201 X Y Z E
  double junction_deviation_mm = -1;                  // M205 J (Marlin)
  double jerk_mm_s[kGcodeAxes] = {-1, -1, -1, -1};    // M205 X Y Z E (mm/s), M566 (mm/min, kept in mm/s)
  double square_corner_mm_s = -1;                     // SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY
  double min_cruise_ratio = -1;                       // SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO
};

// What a G-code text says.
struct ReadGcode {
  bool homed = false, millimetres = false, absolute = false, cold_extrusion = false;
  bool song_started = false, song_ended = false;   // "; song starts" and "; song ends" seen
  bool restores_settings = false;                   // M501, or limits set again after the song
  double start[kGcodeAxes] = {0, 0, 0, 0};          // position when the song starts
  MotionSettings song_settings;                     // the limits in force when the song starts
  std::vector<GcodeMove> moves;                     // the song's moves and dwells
  double end_s = 0;                                 // the song's length at the written feeds
};

// Reads G0/G1 (X Y Z E F, modal), G4 P, G21, G90, G28, G92 E0, M302 P, and the limits: M201,
// M204, M205, M566, M501, SET_VELOCITY_LIMIT. The song is between "; song starts" and "; song
// ends". A move lasts its X/Y/Z distance over the feed, or its E distance when only E moves (as
// Marlin and Klipper time them). Other commands are skipped. Throws GcodeError "line N: ..."
// for a number it cannot read or a move without a feed.
// Called from: the G-code tests, the motion model's benchmark.
ReadGcode read_gcode(const std::string &text);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_GCODE_READER_H

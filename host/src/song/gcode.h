// gcode.h: songs -> G-code moves whose per-axis speeds make a 3D printer's X, Y and Z motors
// sing one voice each (the music2gcode job): printer presets, the pure planner, the writer.
#ifndef STEPCHOIR_HOST_SONG_GCODE_H
#define STEPCHOIR_HOST_SONG_GCODE_H

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "song/song.h"

namespace stepchoir {

// Axes that sing: X, Y, Z, and the extruder E when asked (GcodeOptions::extruder).
constexpr size_t kGcodeAxes = 4;
constexpr size_t kCartesianAxes = 3;  // X, Y, Z: the axes a move's feed is measured on
constexpr size_t kExtruderAxis = 3;
constexpr char kAxisNames[kGcodeAxes] = {'X', 'Y', 'Z', 'E'};
// The extruder sings back and forth inside this much filament either side of where it starts, mm.
constexpr double kExtruderTravelMm = 5.0;

// Default steps per cycle of a note: the seed's 2 (a motor stepping at 2f sounds at f).
constexpr double kDefaultStepsPerCycle = 2.0;
// Feed of the moves to the start position, mm/min (capped by each axis's max feed).
constexpr double kTravelFeedMmPerMin = 3000.0;
// Shortest axis the planner accepts, mm (a bounce needs room to sing).
constexpr double kMinAxisLengthMm = 1.0;
// Most moves one song may make (about 100 MB of G-code; hours of music): a bound on memory for
// absurd songs such as a MIDI note days long.
constexpr size_t kMaxGcodeMoves = 2000000;

// A bad printer description or option: what() says what and where.
class GcodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How a printer's motors move its head.
// - kCartesian: X, Y and Z each have a motor.
// - kCoreXY: motor A moves the head along X + Y and motor B along X - Y, both belts at once
//   (Klipper's stepper_x and stepper_y; Marlin's COREXY; RepRapFirmware's M669 K1, whose motor
//   positions are (X + Y) and (X - Y) times each motor's steps/mm). Z has its own motor.
// - kDelta: three towers' carriages (A, B, C) hold the effector on rods (song/delta_head.h);
//   each carriage sings, and the effector follows.
enum class Kinematics { kCartesian, kCoreXY, kDelta };

// "cartesian", "corexy" or "delta"; throws GcodeError naming where and the choices. Called by
// the preset reader and the command's --kinematics.
Kinematics parse_kinematics(std::string_view name, const std::string &where);
const char *kinematics_name(Kinematics k);
// The letter of the motor that plays axis index a's voice: X Y Z E, A B Z E on CoreXY, A B C E
// (the towers) on a delta.
char motor_name(Kinematics k, size_t a);

// The firmware a printer runs: its motion planner (song/motion_model.h) and the commands that
// set its limits (M201/M204/M205 on Marlin, SET_VELOCITY_LIMIT on Klipper, M201/M204/M566 on
// RepRapFirmware).
enum class Firmware { kMarlin, kKlipper, kRepRap };

// "marlin", "klipper" or "reprap"; throws GcodeError naming where and the choices.
Firmware parse_firmware(std::string_view name, const std::string &where);
const char *firmware_name(Firmware f);

// A printer's motion limits: what its firmware runs with by itself (stock) and the most the
// song's header sets (safe). Acceleration of X and Y in mm/s^2; "corner" in mm/s: Marlin's
// classic jerk (its junction deviation J = 0.4 corner^2 / accel), Klipper's square corner
// velocity, RepRapFirmware's M566 jerk of X and Y.
struct PrinterMotion {
  Firmware firmware = Firmware::kMarlin;
  double accel_stock = 500, accel_safe = 2000;
  double corner_stock = 10, corner_safe = 15;
  double z_accel = 100;              // Z's acceleration limit (M201 Z; Klipper max_z_accel)
  double cruise_ratio_stock = 0.5;   // Klipper's minimum_cruise_ratio (the header sets 0)
};

// One axis of a printer. On CoreXY, axes X and Y give the head's range (min_mm, max_mm) and
// motors A and B's steps per mm of X + Y and X - Y (M92 X and Y) and max feeds along them.
struct PrinterAxis {
  double steps_per_mm = 0;   // firmware steps per millimetre (M92)
  double min_mm = 0;         // lowest coordinate the nozzle may reach
  double max_mm = 0;         // highest coordinate
  double max_feed_mm_s = 0;  // firmware's max feed for this axis (M203); 0 = not checked
};

// A printer preset.
struct Printer {
  std::string name;
  std::string description;
  Kinematics kinematics = Kinematics::kCartesian;
  PrinterMotion motion;
  // Delta only (keys rod=, radius=, printable=): rod length, centre to a tower's carriage joint
  // less the effector's offset (Marlin's DELTA_DIAGONAL_ROD and DELTA_RADIUS), and the radius the
  // effector stays within, mm. Steps/mm and max feeds X, Y, Z are towers A, B, C's carriages';
  // the volume's Z range is the effector's.
  double delta_rod_mm = 0, delta_radius_mm = 0, delta_printable_mm = 0;
  PrinterAxis axes[kGcodeAxes];  // E: steps_per_mm 0 when unknown; range +-kExtruderTravelMm
};

// Parses presets in the format of host/data/printers.conf (after the max feeds, optional
// key=value words: kinematics, firmware, accel, corner, zaccel, rod, radius, printable); source
// names the text in errors
// (source:line). Called by builtin_printers and the `stepchoir gcode` command. Throws GcodeError.
std::vector<Printer> parse_printers(std::string_view text, const std::string &source);

// Makes a printer from text fields: steps/mm "X,Y,Z" or "X,Y,Z,E", volume
// "XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX", max feed "X,Y,Z" or "X,Y,Z,E" in mm/s (empty: not checked);
// where names the source in errors. Called by
// parse_printers and the command's --steps-per-mm/--volume. Throws GcodeError.
Printer make_printer(const std::string &name, std::string_view steps, std::string_view volume,
                     std::string_view max_feed, const std::string &where);

// Throws GcodeError (naming where and the printer) unless a delta printer's rods, radius and
// printable radius make a machine whose effector reaches every point of its printable circle.
// Called by the preset reader and plan_gcode.
void check_delta(const Printer &printer, const std::string &where);

// The presets built into the command (host/data/printers.conf). Called by the command and tests.
const std::vector<Printer> &builtin_printers();

// The preset of that name, or a GcodeError listing the names. Called by the command and tests.
const Printer &find_printer(const std::vector<Printer> &printers, const std::string &name);

// A voice of a song: the notes of one track and channel (.sng: one BEGINCH block). An axis plays
// one voice.
struct Voice {
  uint16_t track = 0;
  uint8_t channel = 0;
  size_t note_count = 0;
};

// The song's voices, ordered by track then channel. Called by plan_gcode and the command.
std::vector<Voice> voices_of(const Song &song);

// How a song becomes G-code.
struct GcodeOptions {
  double steps_per_cycle = kDefaultStepsPerCycle;
  bool home = false;              // G28 before the song
  bool fold_octaves = false;      // notes above an axis's max feed drop octaves until they fit
                                  // (otherwise they are kept and named in a warning)
  bool use_g1 = false;            // G1 instead of G0 (firmware that runs G0 at a fixed speed)
  bool extruder = false;          // E sings a fourth voice (cold extrusion allowed: unload the filament)
  std::vector<size_t> voice_of_axis;  // voices_of() index per axis, X first; empty: voices in order
  Firmware flavor = Firmware::kMarlin;  // whose commands set the motion limits
  bool set_limits = true;         // the header raises acceleration and corner speed to the
                                  // printer's safe figures, and the footer puts its own back
};

// One G-code line of the song: a move (G0 to pos_mm at feed_mm_min) or a dwell (G4).
struct GcodeStep {
  bool dwell = false;
  double pos_mm[kGcodeAxes] = {0, 0, 0, 0};  // move: absolute target
  double feed_mm_min = 0;  // move: feed over X, Y, Z (or E alone when only E moves), mm/min
  double duration_s = 0;                  // move or dwell: how long it lasts
};

// A stretch of the score in which no voice changes: what each axis plays.
struct GcodeSegment {
  double start_s = 0, duration_s = 0;
  int midi_note[kGcodeAxes] = {-1, -1, -1, -1};  // note each axis plays after folding, -1 silent
};

// The planned song.
struct GcodePlan {
  double start_mm[kGcodeAxes] = {0, 0, 0, 0};  // where the song starts (the middle of the volume)
  size_t axis_count = kCartesianAxes;          // axes the G-code drives: 3, or 4 with E
  std::vector<GcodeStep> steps;
  std::vector<GcodeSegment> segments;
  std::vector<Voice> axis_voice;            // voice each used axis plays (size = axes used)
  std::vector<std::string> warnings;        // notes too fast, hidden notes
  double duration_s = 0;                    // end of the last note
};

// Plans the moves of a song on a printer: one segment per change of any voice, each split where
// an axis reaches a border (it reverses at the same speed; on CoreXY, where the head reaches a
// side, A, B or both reverse, whichever leaves the head the longest way). Called by the command
// and tests.
// Throws GcodeError when the voices do not fit the axes or an option is invalid.
GcodePlan plan_gcode(const Song &song, const Printer &printer, const GcodeOptions &options);

// The G-code text of a plan: header (units, absolute positioning, optional homing, move to the
// start), the song between "; song starts" and "; song ends", footer. Called by the command and
// tests.
std::string write_gcode(const GcodePlan &plan, const Printer &printer, const GcodeOptions &options,
                        const std::string &title);

// Name of a MIDI note as the .sng format writes it ("C#4", "A4"). Called by warnings and comments.
std::string note_name(int midi_note);

// v with `decimals` decimals, as G-code and messages write numbers. Called by the writer, the
// planner's warnings and the preset checks.
std::string gcode_number(double v, int decimals);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_GCODE_H

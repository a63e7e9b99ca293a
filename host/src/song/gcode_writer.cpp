// gcode_writer.cpp: a planned song as G-code text: header, the moves, footer. Pure: no I/O.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "song/gcode.h"

namespace stepchoir {

std::string gcode_number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

namespace {

// The commands that set a firmware's acceleration (mm/s^2) and corner speed (mm/s) and, for
// Klipper, its minimum cruise ratio. Called by write_gcode for the header (the printer's safe
// figures) and the footer (its own again).
std::string limits_text(Firmware f, double accel, double corner, double cruise_ratio, double z_accel, const char *why) {
  const std::string a = gcode_number(accel, 0), why_text = std::string(" ; ") + why + "\n";
  switch (f) {
    case Firmware::kKlipper:
      return "SET_VELOCITY_LIMIT ACCEL=" + a + " SQUARE_CORNER_VELOCITY=" + gcode_number(corner, 1) +
             " MINIMUM_CRUISE_RATIO=" + gcode_number(cruise_ratio, 2) + why_text;
    case Firmware::kRepRap:
      return "M201 X" + a + " Y" + a + " Z" + gcode_number(z_accel, 0) + why_text + "M204 P" + a + " T" + a + "\n" +
             "M566 X" + gcode_number(corner * 60, 0) + " Y" + gcode_number(corner * 60, 0) + " ; jerk, mm/min\n";
    case Firmware::kMarlin:
      break;
  }
  return "M201 X" + a + " Y" + a + why_text + "M204 P" + a + " T" + a + "\n" + "M205 X" + gcode_number(corner, 1) +
         " Y" + gcode_number(corner, 1) + " ; classic jerk\n" + "M205 J" +
         gcode_number(0.4 * corner * corner / accel, 4) + " ; junction deviation\n";
}

}  // namespace

std::string write_gcode(const GcodePlan &plan, const Printer &printer, const GcodeOptions &options,
                        const std::string &title) {
  const char *move = options.use_g1 ? "G1" : "G0";
  auto coords = [&](const double *p) {
    std::string s;
    for (size_t a = 0; a < plan.axis_count; ++a) s += std::string(" ") + kAxisNames[a] + gcode_number(p[a], 5);
    return s;
  };
  std::string out;
  std::string safe_title = title;  // a comment line: no control characters
  for (char &c : safe_title)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) c = '?';
  out += "; " + safe_title + "\n";
  out += "; stepchoir gcode: printer " + printer.name + " (" + printer.description + "), " +
         kinematics_name(printer.kinematics) + "\n";
  out += "; steps/mm";
  for (size_t a = 0; a < plan.axis_count; ++a)
    out += std::string(" ") + motor_name(printer.kinematics, a) + gcode_number(printer.axes[a].steps_per_mm, 3);
  out += std::string(", firmware ") + firmware_name(options.flavor);
  out += ", steps per cycle " + gcode_number(options.steps_per_cycle, 3) + ", length " + gcode_number(plan.duration_s, 3) + " s\n";
  for (size_t a = 0; a < plan.axis_voice.size(); ++a)
    out += std::string("; ") + motor_name(printer.kinematics, a) + " plays track " + std::to_string(plan.axis_voice[a].track) +
           " channel " + std::to_string(plan.axis_voice[a].channel) + "\n";
  for (const auto &w : plan.warnings) out += "; warning: " + w + "\n";
  out += "G21 ; millimetres\nG90 ; absolute positions\n";
  const PrinterMotion &pm = printer.motion;
  if (options.set_limits)  // notes reach their pitch sooner: docs/printers.md
    out += limits_text(options.flavor, pm.accel_safe, pm.corner_safe, 0.0, pm.z_accel,
                       "accelerate fast, so that each note is soon at its pitch");
  if (options.home) out += "G28 ; home every axis\n";
  // To the start: Z first (up, from a homed bed), then X and Y, each within its axis's max feed.
  auto travel_mm_min = [&](size_t a) {
    const double limit = printer.axes[a].max_feed_mm_s * 60.0;
    return limit > 0 ? std::min(kTravelFeedMmPerMin, limit) : kTravelFeedMmPerMin;
  };
  out += std::string(move) + " Z" + gcode_number(plan.start_mm[2], 5) + " F" + gcode_number(travel_mm_min(2), 3) +
         " ; to the middle of the volume\n";
  out += std::string(move) + " X" + gcode_number(plan.start_mm[0], 5) + " Y" + gcode_number(plan.start_mm[1], 5) + " F" +
         gcode_number(std::min(travel_mm_min(0), travel_mm_min(1)), 3) + "\n";
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
      out += std::string(move) + coords(st.pos_mm) + " F" + gcode_number(st.feed_mm_min, 3) + "\n";
      written_s += st.duration_s;
    }
  }
  out += "; song ends\nM400 ; wait for the last note\n";
  if (plan.axis_count > kExtruderAxis) out += "M302 P0 ; cold extrusion prevented again\n";
  if (options.set_limits)
    out += options.flavor == Firmware::kMarlin
               ? "M501 ; the printer's own settings again (from its EEPROM)\n"
               : limits_text(options.flavor, pm.accel_stock, pm.corner_stock, pm.cruise_ratio_stock, pm.z_accel,
                             "the printer's own settings again");
  out += "M84 ; motors off\n";
  return out;
}

}  // namespace stepchoir

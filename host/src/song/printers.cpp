// printers.cpp: printer presets for `stepchoir gcode`: the preset format
// (host/data/printers.conf), the built-in presets, lookup by name. Pure: no I/O.
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "song/gcode.h"

namespace stepchoir {

extern const char kPrinterPresetsText[];  // host/data/printers.conf, generated at configure time

namespace {

// Splits text at sep. Called by the field parsers.
std::vector<std::string_view> split(std::string_view text, char sep) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (;;) {
    const size_t at = text.find(sep, start);
    out.push_back(text.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start));
    if (at == std::string_view::npos) return out;
    start = at + 1;
  }
}

// A finite decimal number, the whole word (sign and fraction allowed). Called by the field
// parsers; throws GcodeError naming where and what.
double number(std::string_view w, const std::string &where, const char *what) {
  const std::string s(w);
  char *end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno || !std::isfinite(v) ||
      s.find_first_of("xXnNiI") != std::string::npos)
    throw GcodeError(where + ": expected a number for " + what + ", got '" + s + "'");
  return v;
}

// Comma-separated numbers, one per axis: X,Y,Z or X,Y,Z,E (E left as it is when not given).
// Called by make_printer.
void per_axis(std::string_view w, const std::string &where, const char *what, double out[kGcodeAxes]) {
  const auto parts = split(w, ',');
  if (parts.size() != kCartesianAxes && parts.size() != kGcodeAxes)
    throw GcodeError(where + ": expected " + what + " as X,Y,Z or X,Y,Z,E, got '" + std::string(w) + "'");
  for (size_t a = 0; a < parts.size(); ++a) out[a] = number(parts[a], where, what);
}

// "STOCK:SAFE" as two numbers. Called by read_key.
void stock_and_safe(std::string_view v, const std::string &where, const char *what, double &stock, double &safe) {
  const auto parts = split(v, ':');
  if (parts.size() != 2) throw GcodeError(where + ": expected " + what + "=STOCK:SAFE, got '" + std::string(v) + "'");
  stock = number(parts[0], where, what);
  safe = number(parts[1], where, what);
  if (!(stock > 0) || !(safe >= stock))
    throw GcodeError(where + ": " + what + " " + std::string(v) + ": both above 0, the safe figure at least the stock");
}

// One key=value word of a preset line. Called by parse_printers.
void read_key(std::string_view word, const std::string &where, Printer &p) {
  const size_t eq = word.find('=');
  const std::string_view key = word.substr(0, eq), value = word.substr(eq + 1);
  if (key == "kinematics") {
    p.kinematics = parse_kinematics(value, where);
  } else if (key == "firmware") {
    p.motion.firmware = parse_firmware(value, where);
  } else if (key == "accel") {
    stock_and_safe(value, where, "accel", p.motion.accel_stock, p.motion.accel_safe);
  } else if (key == "corner") {
    stock_and_safe(value, where, "corner", p.motion.corner_stock, p.motion.corner_safe);
  } else if (key == "zaccel") {
    p.motion.z_accel = number(value, where, "zaccel");
    if (!(p.motion.z_accel > 0)) throw GcodeError(where + ": zaccel must be above 0");
  } else if (key == "rod" || key == "radius" || key == "printable") {
    const double v = number(value, where, std::string(key).c_str());
    if (!(v > 0)) throw GcodeError(where + ": " + std::string(key) + " must be above 0");
    (key == "rod" ? p.delta_rod_mm : key == "radius" ? p.delta_radius_mm : p.delta_printable_mm) = v;
  } else {
    throw GcodeError(where + ": unknown key '" + std::string(key) +
                     "' (kinematics, firmware, accel, corner, zaccel, rod, radius, printable)");
  }
}

}  // namespace

Printer make_printer(const std::string &name, std::string_view steps, std::string_view volume,
                             std::string_view max_feed, const std::string &where) {
  Printer p;
  p.name = name;
  double s[kGcodeAxes] = {0, 0, 0, 0}, f[kGcodeAxes] = {0, 0, 0, 0};
  per_axis(steps, where, "steps/mm", s);
  if (!max_feed.empty()) per_axis(max_feed, where, "max feed (mm/s)", f);
  const auto ranges = split(volume, ',');
  if (ranges.size() != kCartesianAxes)
    throw GcodeError(where + ": expected the volume as XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX, got '" + std::string(volume) + "'");
  PrinterAxis &e = p.axes[kExtruderAxis];
  e.steps_per_mm = s[kExtruderAxis];
  e.min_mm = -kExtruderTravelMm;
  e.max_mm = kExtruderTravelMm;
  e.max_feed_mm_s = f[kExtruderAxis];
  if (e.steps_per_mm < 0 || e.steps_per_mm > 1e6) throw GcodeError(where + ": E steps/mm must be 0 to 1000000");
  if (e.max_feed_mm_s < 0) throw GcodeError(where + ": E's max feed is negative");
  for (size_t a = 0; a < kCartesianAxes; ++a) {
    const auto ends = split(ranges[a], ':');
    if (ends.size() != 2)
      throw GcodeError(where + ": expected " + kAxisNames[a] + "'s range as MIN:MAX, got '" + std::string(ranges[a]) + "'");
    PrinterAxis &ax = p.axes[a];
    ax.steps_per_mm = s[a];
    ax.min_mm = number(ends[0], where, "the volume");
    ax.max_mm = number(ends[1], where, "the volume");
    ax.max_feed_mm_s = f[a];
    if (!(ax.steps_per_mm > 0) || ax.steps_per_mm > 1e6)
      throw GcodeError(where + ": " + kAxisNames[a] + " steps/mm must be above 0 and at most 1000000");
    if (!(ax.max_mm - ax.min_mm >= kMinAxisLengthMm))
      throw GcodeError(where + ": " + kAxisNames[a] + "'s range " + std::string(ranges[a]) + " is shorter than " +
                       gcode_number(kMinAxisLengthMm, 0) + " mm");
    if (ax.max_feed_mm_s < 0) throw GcodeError(where + ": " + kAxisNames[a] + "'s max feed is negative");
  }
  return p;
}

std::vector<Printer> parse_printers(std::string_view text, const std::string &source) {
  std::vector<Printer> out;
  int line_no = 0;
  for (std::string_view line : split(text, '\n')) {
    ++line_no;
    const auto w = split_words(line.substr(0, line.find('#')));
    if (w.empty()) continue;
    const std::string where = source + ":" + std::to_string(line_no);
    if (w.size() < 4)
      throw GcodeError(where + ": expected 'name steps/mm volume max-feed description', e.g. "
                               "'ender3 80,80,400 0:220,0:220,0:250 500,500,5 Ender-3'");
    Printer p = make_printer(std::string(w[0]), w[1], w[2], w[3], where);
    size_t first = 4;
    for (; first < w.size() && w[first].find('=') != std::string_view::npos; ++first)
      read_key(w[first], where, p);
    for (size_t i = first; i < w.size(); ++i) p.description += (i > first ? " " : "") + std::string(w[i]);
    for (const auto &q : out)
      if (q.name == p.name) throw GcodeError(where + ": a second printer named '" + p.name + "'");
    if (p.kinematics == Kinematics::kDelta) check_delta(p, where);
    out.push_back(std::move(p));
  }
  if (out.empty()) throw GcodeError(source + ": no printers");
  return out;
}

Kinematics parse_kinematics(std::string_view name, const std::string &where) {
  if (name == "cartesian") return Kinematics::kCartesian;
  if (name == "corexy") return Kinematics::kCoreXY;
  if (name == "delta") return Kinematics::kDelta;
  throw GcodeError(where + ": kinematics '" + std::string(name) + "': expected cartesian, corexy or delta");
}

Firmware parse_firmware(std::string_view name, const std::string &where) {
  if (name == "marlin") return Firmware::kMarlin;
  if (name == "klipper") return Firmware::kKlipper;
  if (name == "reprap") return Firmware::kRepRap;
  throw GcodeError(where + ": firmware '" + std::string(name) + "': expected marlin, klipper or reprap");
}

const char *firmware_name(Firmware f) {
  return f == Firmware::kKlipper ? "klipper" : f == Firmware::kRepRap ? "reprap" : "marlin";
}

const char *kinematics_name(Kinematics k) {
  return k == Kinematics::kCoreXY ? "corexy" : k == Kinematics::kDelta ? "delta" : "cartesian";
}

char motor_name(Kinematics k, size_t a) {
  if (k == Kinematics::kCoreXY && a < 2) return a == 0 ? 'A' : 'B';
  if (k == Kinematics::kDelta && a < 3) return static_cast<char>('A' + a);
  return kAxisNames[a];
}

void check_delta(const Printer &p, const std::string &where) {
  const std::string who = where + ": printer " + p.name + " (delta): ";
  if (!(p.delta_rod_mm > 0) || !(p.delta_radius_mm > 0) || !(p.delta_printable_mm > 0))
    throw GcodeError(who + "needs rod=, radius= and printable= (mm)");
  if (!(p.delta_printable_mm < p.delta_radius_mm))
    throw GcodeError(who + "printable radius " + gcode_number(p.delta_printable_mm, 1) + " mm reaches the towers (radius " +
                     gcode_number(p.delta_radius_mm, 1) + " mm)");
  if (!(p.delta_radius_mm + p.delta_printable_mm < p.delta_rod_mm))
    throw GcodeError(who + "rods of " + gcode_number(p.delta_rod_mm, 1) + " mm cannot reach the edge of the printable " +
                     "radius from the far tower (radius + printable = " +
                     gcode_number(p.delta_radius_mm + p.delta_printable_mm, 1) + " mm): the delta radius is too small " +
                     "for its rods, or the printable radius too large");
}

const std::vector<Printer> &builtin_printers() {
  static const std::vector<Printer> presets = parse_printers(kPrinterPresetsText, "printers.conf");
  return presets;
}

const Printer &find_printer(const std::vector<Printer> &printers, const std::string &name) {
  std::string names;
  for (const auto &p : printers) {
    if (p.name == name) return p;
    names += (names.empty() ? "" : ", ") + p.name;
  }
  throw GcodeError("no printer named '" + name + "'; known: " + names);
}

}  // namespace stepchoir

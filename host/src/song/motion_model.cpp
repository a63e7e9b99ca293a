// motion_model.cpp: the trapezoid planner model and its in-tune measure.
#include "song/motion_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace stepchoir {

MotionLimits printer_limits(const Printer &printer, Firmware firmware, bool safe) {
  const PrinterMotion &m = printer.motion;
  MotionLimits l;
  l.firmware = firmware;
  l.accel_mm_s2 = safe ? m.accel_safe : m.accel_stock;
  const double corner = safe ? m.corner_safe : m.corner_stock;
  // Marlin and RepRapFirmware also limit each axis (M201); Klipper the head, and Z on its own.
  if (firmware != Firmware::kKlipper)
    for (size_t a = 0; a < 2; ++a) l.max_accel_mm_s2[a] = l.accel_mm_s2;
  l.max_accel_mm_s2[2] = m.z_accel;
  l.junction_deviation_mm = 0.4 * corner * corner / l.accel_mm_s2;
  l.square_corner_mm_s = corner;
  l.min_cruise_ratio = safe ? 0.0 : m.cruise_ratio_stock;
  for (size_t a = 0; a < 2; ++a) l.jerk_mm_s[a] = corner;
  return l;
}

MotionLimits with_settings(MotionLimits base, const MotionSettings &s) {
  if (s.accel_mm_s2 > 0) base.accel_mm_s2 = s.accel_mm_s2;
  for (size_t a = 0; a < kGcodeAxes; ++a) {
    if (s.max_accel_mm_s2[a] > 0) base.max_accel_mm_s2[a] = s.max_accel_mm_s2[a];
    if (s.jerk_mm_s[a] >= 0) base.jerk_mm_s[a] = s.jerk_mm_s[a];
  }
  if (s.junction_deviation_mm >= 0) base.junction_deviation_mm = s.junction_deviation_mm;
  if (s.square_corner_mm_s >= 0) base.square_corner_mm_s = s.square_corner_mm_s;
  if (s.min_cruise_ratio >= 0) base.min_cruise_ratio = s.min_cruise_ratio;
  return base;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One move as the planner sees it.
struct Block {
  double length = 0, speed = 0, accel = 0;  // mm, mm/s (written), mm/s^2
  double unit[kGcodeAxes] = {0, 0, 0, 0};   // direction (X, Y, Z; E alone for an E-only move)
  bool after_stop = false;                  // a dwell (or the song's start) comes before it
  double written_s = 0;
};

// The fastest speed (mm/s) at the junction from block p into block n under the firmware's
// rule (before the caps of the two speeds and of reachability).
double junction_speed(const Block &p, const Block &n, const MotionLimits &l) {
  double cos_turn = 0;  // cosine of the angle between the directions
  for (size_t a = 0; a < kGcodeAxes; ++a) cos_turn += p.unit[a] * n.unit[a];
  cos_turn = std::clamp(cos_turn, -1.0, 1.0);
  if (l.firmware == Firmware::kRepRap) {  // each axis's speed may jump by its jerk
    double v = kInf;
    for (size_t a = 0; a < kGcodeAxes; ++a) {
      const double change = std::fabs(p.unit[a] - n.unit[a]);
      if (change > 1e-12) v = std::min(v, l.jerk_mm_s[a] / change);
    }
    return v;
  }
  // Junction deviation (Marlin's own, or Klipper's from its square corner velocity).
  const double accel = std::min(p.accel, n.accel);
  const double jd = l.firmware == Firmware::kKlipper
                        ? l.square_corner_mm_s * l.square_corner_mm_s * (std::sqrt(2.0) - 1) / l.accel_mm_s2
                        : l.junction_deviation_mm;
  // sin(t/2), t the angle between the reversed incoming direction and the outgoing one: 1
  // straight on, 0 for a reversal
  const double s = std::sqrt(std::max(0.0, 0.5 * (1 + cos_turn)));
  if (s >= 1 - 1e-12) return kInf;  // straight on
  double v2 = accel * jd * s / (1 - s);
  if (l.firmware == Firmware::kKlipper && s > 1e-12) {  // the centripetal limit of the shorter move's half
    const double tan_half = s / std::sqrt(std::max(1e-24, 1 - s * s));
    v2 = std::min(v2, 0.5 * std::min(p.length, n.length) * tan_half * accel);
  }
  return std::sqrt(std::max(0.0, v2));
}

}  // namespace

MotionReport model_motion(const ReadGcode &gcode, const MotionLimits &limits, double cents) {
  std::vector<Block> blocks;
  bool stopped = true;
  for (const GcodeMove &m : gcode.moves) {
    if (m.dwell) {
      stopped = true;
      continue;
    }
    Block b;
    double d2 = 0;
    for (size_t a = 0; a < kCartesianAxes; ++a) d2 += (m.to[a] - m.from[a]) * (m.to[a] - m.from[a]);
    const bool e_only = d2 == 0;
    if (e_only) d2 = (m.to[kExtruderAxis] - m.from[kExtruderAxis]) * (m.to[kExtruderAxis] - m.from[kExtruderAxis]);
    b.length = std::sqrt(d2);
    if (!(b.length > 0)) continue;
    for (size_t a = 0; a < kGcodeAxes; ++a)
      if (e_only == (a == kExtruderAxis)) b.unit[a] = (m.to[a] - m.from[a]) / b.length;
    b.speed = m.feed_mm_min / 60.0;
    b.accel = limits.accel_mm_s2;
    for (size_t a = 0; a < kGcodeAxes; ++a)  // no axis above its own limit
      if (limits.max_accel_mm_s2[a] > 0 && std::fabs(b.unit[a]) > 1e-12)
        b.accel = std::min(b.accel, limits.max_accel_mm_s2[a] / std::fabs(b.unit[a]));
    b.after_stop = stopped;
    b.written_s = m.duration_s;
    stopped = false;
    blocks.push_back(b);
  }
  const size_t n = blocks.size();
  // entry[i]: the speed at which block i starts; entry[n]: the end (a stop).
  std::vector<double> entry(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i)
    entry[i] = blocks[i].after_stop || i == 0
                   ? 0.0
                   : std::min({blocks[i - 1].speed, blocks[i].speed, junction_speed(blocks[i - 1], blocks[i], limits)});
  for (size_t i = 0; i + 1 < n; ++i)  // a block before a dwell ends at rest
    if (blocks[i + 1].after_stop) entry[i + 1] = 0;
  for (size_t i = n; i-- > 0;)  // backward: each block can slow to the next one's entry
    entry[i] = std::min(entry[i], std::sqrt(entry[i + 1] * entry[i + 1] + 2 * blocks[i].accel * blocks[i].length));
  for (size_t i = 0; i < n; ++i)  // forward: each block can reach its exit from its entry
    entry[i + 1] = std::min(entry[i + 1], std::sqrt(entry[i] * entry[i] + 2 * blocks[i].accel * blocks[i].length));

  const double low = std::pow(2.0, -cents / 1200.0);  // slowest in-tune share of the written speed
  MotionReport r;
  for (size_t i = 0; i < n; ++i) {
    const Block &b = blocks[i];
    const double a = b.accel, v_in = entry[i], v_out = entry[i + 1];
    // The top speed: the written one, or what the distance allows (Klipper keeps a share of it
    // at cruise).
    const double reach = a * b.length * (limits.firmware == Firmware::kKlipper ? 1 - limits.min_cruise_ratio : 1.0);
    const double peak = std::min(b.speed, std::sqrt(std::max(0.0, (2 * reach + v_in * v_in + v_out * v_out) / 2)));
    const double up_s = (peak - v_in) / a, down_s = (peak - v_out) / a;
    const double cruise_mm = b.length - (peak * peak - v_in * v_in) / (2 * a) - (peak * peak - v_out * v_out) / (2 * a);
    const double cruise_s = std::max(0.0, cruise_mm) / peak;
    const double total_s = up_s + cruise_s + down_s;
    double tune_s = 0;
    const double floor = low * b.speed;
    if (peak >= floor) {
      tune_s = cruise_s + (v_in >= floor ? up_s : (peak - floor) / a) + (v_out >= floor ? down_s : (peak - floor) / a);
    }
    r.note_s += total_s;
    r.in_tune_s += tune_s;
    r.written_s += b.written_s;
    ++r.moves;
    r.moves_in_tune += tune_s >= 0.9 * total_s;
  }
  return r;
}

HeaderEffect header_effect(const Song &song, const Printer &printer, GcodeOptions options) {
  const MotionLimits own = printer_limits(printer, options.flavor, false);
  HeaderEffect e;
  for (const bool set : {false, true}) {
    options.set_limits = set;
    const ReadGcode g = read_gcode(write_gcode(plan_gcode(song, printer, options), printer, options, "song"));
    (set ? e.header : e.own) = model_motion(g, with_settings(own, g.song_settings));
  }
  return e;
}

}  // namespace stepchoir

// delta_head.cpp: delta kinematics, the effector's straight moves and the carriages' reversals.
#include "song/delta_head.h"

#include <cmath>

#include "song/gcode.h"

namespace stepchoir {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Tower angles (degrees): A front left, B front right, C at the back.
constexpr double kTowerDeg[3] = {210, 330, 90};
// Time steps of the border search, s.
constexpr double kProbeS = 0.001;
// A straight move lasts at least this long (s); the recursion that splits moves stops there.
constexpr double kShortestMoveS = 0.0002;
// A moving carriage's position may stray from its line by this share of its speed times the
// move's duration (its speed by four times that: 0.4 %); a silent one by this share of a step.
constexpr double kStrayShare = 0.001;
constexpr double kSilentStraySteps = 0.25;

Vec3 tower(const DeltaGeometry &g, int t) {
  const double a = kTowerDeg[t] * kPi / 180;
  return {g.radius_mm * std::cos(a), g.radius_mm * std::sin(a), 0};
}

Vec3 sub(const Vec3 &a, const Vec3 &b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3 &a, const Vec3 &b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 scale(const Vec3 &a, double k) { return {a[0] * k, a[1] * k, a[2] * k}; }
Vec3 add(const Vec3 &a, const Vec3 &b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 cross(const Vec3 &a, const Vec3 &b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

bool delta_inverse(const DeltaGeometry &g, const Vec3 &p, Vec3 *heights) {
  for (int t = 0; t < 3; ++t) {
    const Vec3 tw = tower(g, t);
    const double r2 = g.rod_mm * g.rod_mm - (p[0] - tw[0]) * (p[0] - tw[0]) - (p[1] - tw[1]) * (p[1] - tw[1]);
    if (!(r2 > 0)) return false;
    (*heights)[t] = p[2] + std::sqrt(r2);
  }
  return true;
}

bool delta_forward(const DeltaGeometry &g, const Vec3 &heights, Vec3 *p) {
  Vec3 c[3];
  for (int t = 0; t < 3; ++t) {
    c[t] = tower(g, t);
    c[t][2] = heights[t];
  }
  // Trilateration with equal radii: the rods' ends meet where three spheres of radius rod do.
  const Vec3 d21 = sub(c[1], c[0]), d31 = sub(c[2], c[0]);
  const double d = std::sqrt(dot(d21, d21));
  const Vec3 ex = scale(d21, 1 / d);
  const double i = dot(ex, d31);
  const Vec3 ey_raw = sub(d31, scale(ex, i));
  const double j = std::sqrt(dot(ey_raw, ey_raw));
  const Vec3 ey = scale(ey_raw, 1 / j);
  const Vec3 ez = cross(ex, ey);
  const double x = d / 2;
  const double y = (i * i + j * j) / (2 * j) - i * x / j;
  const double z2 = g.rod_mm * g.rod_mm - x * x - y * y;
  if (!(z2 > 0)) return false;
  const Vec3 base = add(c[0], add(scale(ex, x), scale(ey, y)));
  const Vec3 a = add(base, scale(ez, std::sqrt(z2))), b = sub(base, scale(ez, std::sqrt(z2)));
  *p = a[2] < b[2] ? a : b;  // below the carriages
  return true;
}

DeltaHead::DeltaHead(const DeltaGeometry &g, const Vec3 &start, const Vec3 &steps_per_mm)
    : g_(g), steps_per_mm_(steps_per_mm), effector_(start) {
  if (!delta_inverse(g_, start, &heights_)) throw GcodeError("delta: the rods cannot reach the start position");
}

bool DeltaHead::inside(const Vec3 &p) const {
  return p[0] * p[0] + p[1] * p[1] <= g_.printable_mm * g_.printable_mm && p[2] >= g_.z_min_mm && p[2] <= g_.z_max_mm;
}

bool DeltaHead::effector_after(double dt, Vec3 *p) const {
  Vec3 h;
  for (int t = 0; t < 3; ++t) h[t] = heights_[t] + dir_[t] * speed_[t] * dt;
  return delta_forward(g_, h, p) && inside(*p);
}

double DeltaHead::time_to_border(double horizon_s) const {
  Vec3 p;
  double inside_s = 0;
  for (double t = kProbeS;; t += kProbeS) {
    const double probe = std::min(t, horizon_s);
    if (!effector_after(probe, &p)) {
      double lo = inside_s, hi = probe;  // the border lies between
      for (int k = 0; k < 50 && hi - lo > 1e-12; ++k) {
        const double mid = (lo + hi) / 2;
        (effector_after(mid, &p) ? lo : hi) = mid;
      }
      return lo;
    }
    inside_s = probe;
    if (probe >= horizon_s) return horizon_s;
  }
}

bool DeltaHead::choose(unsigned free, double horizon_s) {
  const double keep[3] = {dir_[0], dir_[1], dir_[2]};
  double best_time = 0, best[3] = {keep[0], keep[1], keep[2]};
  int best_flips = 4;
  for (unsigned flip = 0; flip < 8; ++flip) {
    if ((flip & ~free) != 0) continue;
    int flips = 0;
    for (int t = 0; t < 3; ++t) {
      dir_[t] = flip >> t & 1 ? -keep[t] : keep[t];
      flips += flip >> t & 1;
    }
    const double time = time_to_border(horizon_s);
    if (time > best_time || (time == best_time && time > 0 && flips < best_flips)) {
      best_time = time;
      best_flips = flips;
      for (int t = 0; t < 3; ++t) best[t] = dir_[t];
    }
  }
  for (int t = 0; t < 3; ++t) dir_[t] = best[t];
  return best_time > 0;
}

void DeltaHead::chords(double t0, const Vec3 &p0, double t1, const Vec3 &p1, std::vector<DeltaMove> &out, int depth,
                       size_t max_moves) const {
  const double tm = (t0 + t1) / 2;
  Vec3 h_true, pm, h_chord;
  for (int t = 0; t < 3; ++t) h_true[t] = heights_[t] + dir_[t] * speed_[t] * tm;
  bool close = delta_forward(g_, h_true, &pm) && delta_inverse(g_, scale(add(p0, p1), 0.5), &h_chord);
  for (int t = 0; close && t < 3; ++t) {
    const double allowed = speed_[t] > 0 ? kStrayShare * speed_[t] * (t1 - t0) : kSilentStraySteps / steps_per_mm_[t];
    close = std::fabs(h_chord[t] - h_true[t]) <= allowed;
  }
  if (close || depth >= 40 || t1 - t0 < 2 * kShortestMoveS) {
    if (out.size() >= max_moves) throw GcodeError("the song takes more than the moves a G-code file is allowed here");
    out.push_back({p1, t1 - t0});
    return;
  }
  chords(t0, p0, tm, pm, out, depth + 1, max_moves);
  chords(tm, pm, t1, p1, out, depth + 1, max_moves);
}

void DeltaHead::advance(double dt, std::vector<DeltaMove> &out, size_t max_moves) {
  if (!(dt > 0)) return;
  Vec3 h, p1;
  for (int t = 0; t < 3; ++t) h[t] = heights_[t] + dir_[t] * speed_[t] * dt;
  if (!delta_forward(g_, h, &p1)) throw GcodeError("delta: the rods cannot meet (the effector left the printable space)");
  chords(0, effector_, dt, p1, out, 0, max_moves);
  heights_ = h;
  effector_ = p1;
}

}  // namespace stepchoir

// corexy_head.cpp: a CoreXY head's sides and its motors' reversals.
#include "song/corexy_head.h"

#include <algorithm>
#include <limits>

namespace stepchoir {

CoreXYHead::CoreXYHead(double x, double y, double xmin, double xmax, double ymin, double ymax, double at_side_mm)
    : x_(x), y_(y), xmin_(xmin), xmax_(xmax), ymin_(ymin), ymax_(ymax), at_side_mm_(at_side_mm) {}

namespace {

// Seconds until a coordinate at p moving at v reaches lo or hi (infinite when still or when it
// is at the side it heads for).
double time_to(double p, double v, double lo, double hi) {
  if (v > 0) return (hi - p) / v;
  if (v < 0) return (p - lo) / -v;
  return std::numeric_limits<double>::infinity();
}

}  // namespace

double CoreXYHead::time_to_side() const {
  return std::min(time_to(x_, vx(), xmin_, xmax_), time_to(y_, vy(), ymin_, ymax_));
}

bool CoreXYHead::heading_out() const {
  const double vx_ = vx(), vy_ = vy();
  return (vx_ > 0 && xmax_ - x_ <= at_side_mm_) || (vx_ < 0 && x_ - xmin_ <= at_side_mm_) ||
         (vy_ > 0 && ymax_ - y_ <= at_side_mm_) || (vy_ < 0 && y_ - ymin_ <= at_side_mm_);
}

bool CoreXYHead::choose(unsigned free) {
  const double keep[2] = {dir_[0], dir_[1]};
  double best_time = -1;
  int best_flips = 3;
  double best[2] = {keep[0], keep[1]};
  for (unsigned flip = 0; flip < 4; ++flip) {
    if ((flip & ~free) != 0) continue;
    dir_[0] = flip & 1 ? -keep[0] : keep[0];
    dir_[1] = flip & 2 ? -keep[1] : keep[1];
    if (heading_out()) continue;
    const double t = time_to_side();
    const int flips = static_cast<int>(flip & 1) + static_cast<int>((flip >> 1) & 1);
    if (t > best_time || (t == best_time && flips < best_flips)) {
      best_time = t;
      best_flips = flips;
      best[0] = dir_[0];
      best[1] = dir_[1];
    }
  }
  dir_[0] = best[0];
  dir_[1] = best[1];
  return best_time > 0;
}

void CoreXYHead::advance(double dt) {
  x_ = std::clamp(x_ + vx() * dt, xmin_, xmax_);
  y_ = std::clamp(y_ + vy() * dt, ymin_, ymax_);
  if (xmax_ - x_ <= at_side_mm_) x_ = xmax_;
  if (x_ - xmin_ <= at_side_mm_) x_ = xmin_;
  if (ymax_ - y_ <= at_side_mm_) y_ = ymax_;
  if (y_ - ymin_ <= at_side_mm_) y_ = ymin_;
}

}  // namespace stepchoir

// corexy_head.h: the head of a CoreXY printer while motors A and B sing: where it is, where it
// heads, and which motors reverse when it reaches a side. Pure; used by the G-code planner.
//
// A moves the head along X + Y and B along X - Y (mm of those coordinates), so with A at speed
// sA in direction dA and B at sB in dB the head moves at vx = (dA sA + dB sB) / 2,
// vy = (dA sA - dB sB) / 2. Each motor keeps its speed (its pitch); only directions change.
#ifndef STEPCHOIR_HOST_SONG_COREXY_HEAD_H
#define STEPCHOIR_HOST_SONG_COREXY_HEAD_H

namespace stepchoir {

class CoreXYHead {
 public:
  // A head at (x, y) inside [xmin, xmax] x [ymin, ymax] (mm); `at_side_mm`: closer than this to
  // a side, the head is at it.
  CoreXYHead(double x, double y, double xmin, double xmax, double ymin, double ymax, double at_side_mm);

  // Motor m's (0 = A, 1 = B) speed, mm of its coordinate per s (0: silent). Called per segment.
  void set_speed(int m, double mm_s) { speed_[m] = mm_s; }
  bool moving() const { return speed_[0] > 0 || speed_[1] > 0; }
  double x() const { return x_; }
  double y() const { return y_; }
  // The head's velocity, mm/s.
  double vx() const { return (dir_[0] * speed_[0] + dir_[1] * speed_[1]) / 2; }
  double vy() const { return (dir_[0] * speed_[0] - dir_[1] * speed_[1]) / 2; }

  // Seconds until the head reaches a side it is not at (infinite when it stands still).
  double time_to_side() const;
  // True when the head is at a side and moving out through it.
  bool heading_out() const;
  // Chooses directions for the motors in `free` (bit 0: A, bit 1: B; the others keep theirs):
  // of the choices that do not head out through a side the head is at, the one with the
  // longest time to a side, the fewest reversals on a tie. False when every choice heads out
  // (the head in a corner that the free motors cannot leave).
  bool choose(unsigned free);
  // Moves the head for dt seconds; a head within at_side_mm of a side lands on it.
  void advance(double dt);

 private:
  double x_, y_, xmin_, xmax_, ymin_, ymax_, at_side_mm_;
  double speed_[2] = {0, 0};
  double dir_[2] = {1, 1};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_COREXY_HEAD_H

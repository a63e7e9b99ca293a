// delta_head.h: a linear delta printer (Kossel style) while its three tower carriages sing:
// where the effector is, the straight G-code moves that follow it, and which carriages reverse
// before it leaves the printable space. Pure; used by the G-code planner.
//
// Towers A, B and C stand at angles 210, 330 and 90 degrees on a circle of `radius` mm round
// the bed's centre (Marlin's layout); a rod of `rod` mm joins each carriage to the effector. A
// carriage at height h_i holds the effector at (x, y, z) with
// h_i = z + sqrt(rod^2 - (x - tx_i)^2 - (y - ty_i)^2) (inverse kinematics); the effector of three
// carriages is where the three rods meet (forward kinematics). Each carriage moves at its note's
// speed, so the effector's path is curved: it is written as straight moves short enough that
// every carriage keeps within 0.5 % of its speed (a silent one within a quarter of a step of
// where it stands).
#ifndef STEPCHOIR_HOST_SONG_DELTA_HEAD_H
#define STEPCHOIR_HOST_SONG_DELTA_HEAD_H

#include <array>
#include <cstddef>
#include <vector>

namespace stepchoir {

struct DeltaGeometry {
  double rod_mm = 0;        // diagonal rod length
  double radius_mm = 0;     // centre to a tower's carriage joint, less the effector's offset
  double printable_mm = 0;  // the effector stays within this radius of the centre
  double z_min_mm = 0, z_max_mm = 0;
};

using Vec3 = std::array<double, 3>;

// The carriage heights that hold the effector at p; false when a rod cannot reach it.
bool delta_inverse(const DeltaGeometry &g, const Vec3 &p, Vec3 *heights);
// The effector held by carriages at `heights` (the solution below them); false when the rods
// cannot meet.
bool delta_forward(const DeltaGeometry &g, const Vec3 &heights, Vec3 *p);

// One straight move of the effector: its end and how long it takes.
struct DeltaMove {
  Vec3 to;
  double duration_s;
};

class DeltaHead {
 public:
  // The effector at `start` (inside the printable space); steps_per_mm of each carriage.
  DeltaHead(const DeltaGeometry &g, const Vec3 &start, const Vec3 &steps_per_mm);

  // Carriage t's speed, mm/s (0: silent). Called per segment.
  void set_speed(int t, double mm_s) { speed_[t] = mm_s; }
  bool moving() const { return speed_[0] > 0 || speed_[1] > 0 || speed_[2] > 0; }
  const Vec3 &effector() const { return effector_; }

  // Seconds until the effector would leave the printable space (up to `horizon_s`).
  double time_to_border(double horizon_s) const;
  // Chooses directions for the carriages in `free` (bit t: carriage t) that keep the effector
  // inside longest (up to horizon_s), the fewest reversals on a tie. False when none does.
  bool choose(unsigned free, double horizon_s);
  // Moves the carriages on by dt seconds and appends the straight moves that follow the
  // effector. Throws GcodeError when more than max_moves are out.
  void advance(double dt, std::vector<DeltaMove> &out, std::size_t max_moves);

 private:
  // The effector when the carriages have moved on by dt; false outside the printable space.
  bool effector_after(double dt, Vec3 *p) const;
  bool inside(const Vec3 &p) const;
  void chords(double t0, const Vec3 &p0, double t1, const Vec3 &p1, std::vector<DeltaMove> &out, int depth,
              std::size_t max_moves) const;

  DeltaGeometry g_;
  Vec3 steps_per_mm_;
  Vec3 heights_{}, effector_{};
  double speed_[3] = {0, 0, 0};
  double dir_[3] = {1, 1, 1};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_DELTA_HEAD_H

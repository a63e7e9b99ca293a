// carriage.cpp: carriage position, step counters and overshoot tracking.
#include "carriage.h"

namespace vboard {

namespace {
// Distance beyond [0, travel] in steps, 0 when on the rail.
int64_t beyond_rail_steps(int64_t position_steps, int64_t travel_steps) {
  if (position_steps < 0) return -position_steps;
  if (position_steps > travel_steps) return position_steps - travel_steps;
  return 0;
}
}  // namespace

// Starts the carriage at start_position_steps on a rail of travel_steps.
Carriage::Carriage(int64_t travel_steps, int64_t start_position_steps)
    : travel_steps_(travel_steps),
      position_steps_(start_position_steps),
      overshoot_steps_(beyond_rail_steps(start_position_steps, travel_steps)) {}

// Applies one STEP rising edge; returns true when the carriage moved.
bool Carriage::step(bool dir_high, bool driver_ready) {
  if (!driver_ready) {
    ++lost_steps_;
    return false;
  }
  position_steps_ += dir_high ? 1 : -1;
  ++steps_;
  const int64_t beyond_steps = beyond_rail_steps(position_steps_, travel_steps_);
  if (beyond_steps > overshoot_steps_) overshoot_steps_ = beyond_steps;
  return true;
}

}  // namespace vboard

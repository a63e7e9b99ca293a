// carriage.h: one motor's carriage on a rail of fixed travel, moved by STEP pulses (pure logic).
#ifndef STEPCHOIR_VBOARD_CARRIAGE_H
#define STEPCHOIR_VBOARD_CARRIAGE_H

#include <cstdint>

namespace vboard {

// Position in steps on a rail from 0 to travel_steps. The position is never clamped (a runaway
// must stay visible), but the distance beyond either end is tracked as "overshoot".
class Carriage {
 public:
  // Starts the carriage at start_position_steps on a rail of travel_steps.
  Carriage(int64_t travel_steps, int64_t start_position_steps);

  // Applies one STEP rising edge; moves +1 (dir high) or -1 (dir low) only when the driver
  // takes steps (enabled, awake, out of reset). Returns true when the carriage moved.
  bool step(bool dir_high, bool driver_ready);

  // Current position in steps.
  int64_t position_steps() const { return position_steps_; }
  // Rail length in steps.
  int64_t travel_steps() const { return travel_steps_; }
  // True when the carriage touches or is beyond the min end (position <= 0).
  bool at_min() const { return position_steps_ <= 0; }
  // True when the carriage touches or is beyond the max end (position >= travel).
  bool at_max() const { return position_steps_ >= travel_steps_; }
  // Largest distance ever seen beyond [0, travel], in steps.
  int64_t overshoot_steps() const { return overshoot_steps_; }
  // STEP pulses that moved the carriage.
  uint64_t steps() const { return steps_; }
  // STEP pulses the driver did not take (disabled, asleep or still waking, in reset): lost.
  uint64_t lost_steps() const { return lost_steps_; }

 private:
  int64_t travel_steps_;
  int64_t position_steps_;
  int64_t overshoot_steps_ = 0;
  uint64_t steps_ = 0;
  uint64_t lost_steps_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_CARRIAGE_H

// velocity.h: velocity -> loudness. A stepper has one volume, but motors in unison are louder: a
// kPoly note struck hard takes one or two free motors more, playing its pitch with it. Pure;
// called from: the Allocator on the engine thread (no allocation).
//
// Where a driver's microstep selects (M0-M2) are wired to the board, velocity could pick full
// step (loudest) or microsteps instead. On the supported rigs they are jumpers (the Uno's CNC
// Shield V3 and the Mega's RAMPS 1.4: M0-M2 are kNoPin in firmware/stepchoir/boards/), so
// every rig gets unison doubling only.
#ifndef STEPCHOIR_HOST_LIVE_VELOCITY_H
#define STEPCHOIR_HOST_LIVE_VELOCITY_H

#include <cstdint>

namespace stepchoir {

// The two thresholds, MIDI velocity 1-127. Each counts on its own: a note-on at velocity v takes
// one extra motor when v >= double_at and one more when v >= triple_at. A threshold of 0 or
// above 127 is off.
struct VelocityConfig {
  uint8_t double_at = 100;  // from this velocity a note takes a second motor
  uint8_t triple_at = 120;  // from this velocity a third

  // Motors a note-on at velocity (1-127) takes besides its own: 0, 1 or 2.
  constexpr uint8_t extra_motors(uint8_t velocity) const noexcept {
    return static_cast<uint8_t>(reached(double_at, velocity) + reached(triple_at, velocity));
  }

 private:
  static constexpr bool reached(uint8_t at, uint8_t velocity) noexcept {
    return at >= 1 && at <= 127 && velocity >= at;
  }
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_VELOCITY_H

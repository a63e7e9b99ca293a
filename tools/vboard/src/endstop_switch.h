// endstop_switch.h: a mechanical end switch: logical state, pin level and contact chatter (pure logic).
#ifndef STEPCHOIR_VBOARD_ENDSTOP_SWITCH_H
#define STEPCHOIR_VBOARD_ENDSTOP_SWITCH_H

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vboard {

// One change of the switch's input pin.
struct SwitchPinEvent {
  uint64_t cycle;  // when the pin takes this level
  bool level;      // pin level (true = high)
  bool bounce;     // true for a chatter toggle, false for the logical change itself
};

// Small deterministic PRNG (splitmix64) so chatter is reproducible run to run.
class SplitMix64 {
 public:
  // Seeds the generator.
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  // Next 64 random bits.
  uint64_t next();
  // Uniform integer in [lo, hi] (hi >= lo).
  uint64_t uniform(uint64_t lo, uint64_t hi);

 private:
  uint64_t state_;
};

// A switch wired to one input pin. Pressing or releasing it changes the pin at once, then,
// with chatter enabled, the contact bounces: an even number (2, 4 or 6) of extra toggles
// spread over chatter_cycles, so the pin settles at the new level.
class EndstopSwitch {
 public:
  // active_low: a pressed switch reads LOW. chatter_cycles 0 disables bouncing.
  EndstopSwitch(bool active_low, uint64_t chatter_cycles, uint64_t seed);

  // Logical state (true = pressed).
  bool pressed() const { return pressed_; }
  // Pin level for a logical state.
  bool level_for(bool pressed) const { return pressed != active_low_; }
  // Current pin level (follows the due events the caller has popped).
  bool pin_level() const { return pin_level_; }

  // Sets the power-up state: no events, no chatter, pin at the matching level.
  void reset_to(bool pressed);
  // Changes the logical state at now_cycles; queues the pin events. Returns false if unchanged.
  // A change while the contact still bounces drops the old bounces.
  bool set_pressed(bool pressed, uint64_t now_cycles);

  // True when pin events are waiting.
  bool has_pending() const { return next_index_ < pending_.size(); }
  // Cycle of the next waiting event (only valid when has_pending()).
  uint64_t next_event_cycle() const { return pending_[next_index_].cycle; }
  // Pops the next event if it is due at now_cycles; returns false when none is due.
  bool pop_due(uint64_t now_cycles, SwitchPinEvent &event);

 private:
  bool active_low_;
  uint64_t chatter_cycles_;
  SplitMix64 rng_;
  bool pressed_ = false;
  bool pin_level_;
  std::vector<SwitchPinEvent> pending_;
  size_t next_index_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_ENDSTOP_SWITCH_H

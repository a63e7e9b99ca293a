// endstop_switch.cpp: switch state changes and deterministic contact-bounce schedules.
#include "endstop_switch.h"

#include <algorithm>

namespace vboard {

// Next 64 random bits (splitmix64).
uint64_t SplitMix64::next() {
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Uniform integer in [lo, hi] (hi >= lo); the modulo bias is irrelevant here.
uint64_t SplitMix64::uniform(uint64_t lo, uint64_t hi) {
  return lo + next() % (hi - lo + 1);
}

// Creates a released switch; its pin starts at the released level.
EndstopSwitch::EndstopSwitch(bool active_low, uint64_t chatter_cycles, uint64_t seed)
    : active_low_(active_low),
      chatter_cycles_(chatter_cycles),
      rng_(seed),
      pin_level_(level_for(false)) {}

// Sets the power-up state: no events, no chatter.
void EndstopSwitch::reset_to(bool pressed) {
  pressed_ = pressed;
  pin_level_ = level_for(pressed);
  pending_.clear();
  next_index_ = 0;
}

// Changes the logical state at now_cycles and queues the pin change plus any bounces.
bool EndstopSwitch::set_pressed(bool pressed, uint64_t now_cycles) {
  if (pressed == pressed_) return false;
  pressed_ = pressed;
  pending_.clear();
  next_index_ = 0;
  const bool settled_level = level_for(pressed);
  pending_.push_back({now_cycles, settled_level, false});
  if (chatter_cycles_ == 0) return true;

  // 2, 4 or 6 toggles (even, so the pin ends at the settled level) at distinct random offsets.
  const uint64_t toggle_count = 2 * rng_.uniform(1, 3);
  std::vector<uint64_t> offsets_cycles;
  for (uint64_t i = 0; i < toggle_count; ++i)
    offsets_cycles.push_back(rng_.uniform(1, std::max<uint64_t>(chatter_cycles_, toggle_count)));
  std::sort(offsets_cycles.begin(), offsets_cycles.end());
  for (size_t i = 1; i < offsets_cycles.size(); ++i)
    if (offsets_cycles[i] <= offsets_cycles[i - 1]) offsets_cycles[i] = offsets_cycles[i - 1] + 1;
  bool level = settled_level;
  for (uint64_t offset_cycles : offsets_cycles) {
    level = !level;
    pending_.push_back({now_cycles + offset_cycles, level, true});
  }
  return true;
}

// Pops the next event if it is due at now_cycles.
bool EndstopSwitch::pop_due(uint64_t now_cycles, SwitchPinEvent &event) {
  if (!has_pending() || pending_[next_index_].cycle > now_cycles) return false;
  event = pending_[next_index_++];
  pin_level_ = event.level;
  if (!has_pending()) {
    pending_.clear();
    next_index_ = 0;
  }
  return true;
}

}  // namespace vboard

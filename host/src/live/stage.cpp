// stage.cpp: action names and the learned-controller table (see stage.h for the rules).
#include "live/stage.h"

namespace stepchoir {
namespace {

constexpr const char *kNames[kActionCount] = {
    "transpose_up", "transpose_down", "octave_up",     "octave_down",      "glide_time", "vibrato_depth", "vibrato_rate",
    "preset_next",  "preset_previous", "setlist_next", "setlist_previous", "panic",      "mute_motor"};

}  // namespace

const char *action_name(Action a) noexcept {
  const size_t i = static_cast<size_t>(a);
  return i < kActionCount ? kNames[i] : "?";
}

std::optional<Action> parse_action(std::string_view name) noexcept {
  for (size_t i = 0; i < kActionCount; ++i)
    if (name == kNames[i]) return static_cast<Action>(i);
  return std::nullopt;
}

bool ControlMap::bind(const Binding &b) noexcept {
  if (b.cc >= kCcAllSoundOff || b.channel < -1 || b.channel > 15 || static_cast<size_t>(b.action) >= kActionCount)
    return false;
  // One controller an action: drop what this controller or this action (and motor) had.
  size_t kept = 0;
  for (size_t i = 0; i < count_; ++i) {
    const Binding &old = bindings_[i];
    const bool same_control = old.cc == b.cc && old.channel == b.channel;
    const bool same_action = old.action == b.action && (b.action != Action::kMuteMotor || old.motor == b.motor);
    if (same_control || same_action) continue;
    bindings_[kept] = old;
    last_[kept++] = last_[i];
  }
  count_ = kept;
  if (count_ == kMaxBindings) return false;
  last_[count_] = 0;
  bindings_[count_++] = b;
  return true;
}

bool ControlMap::claim(const MidiEvent &e, StageAction *out, bool *fire) noexcept {
  if ((e.status & 0xF0) != kMidiControlChange || e.data2 > 127) return false;
  const int8_t ch = static_cast<int8_t>(e.status & 0x0F);
  for (size_t i = 0; i < count_; ++i) {
    const Binding &b = bindings_[i];
    if (b.cc != e.data1 || (b.channel >= 0 && b.channel != ch)) continue;
    const uint8_t before = last_[i];
    last_[i] = e.data2;
    *out = StageAction{b.action, e.data2, b.motor};
    *fire = action_is_knob(b.action) || (e.data2 >= 64 && (before < 64 || before == e.data2));
    return true;
  }
  return false;
}

}  // namespace stepchoir

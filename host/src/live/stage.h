// stage.h: the performer's stage actions, triggered from a learned MIDI controller (MIDI learn,
// the rig file's [[controls]]) or a console key, and the table of learned controllers that the
// engine consults before the allocator sees a control change.
//
// Two kinds of action:
//   buttons (transpose, octave, preset and setlist steps, panic, mute motor N) fire on a press:
//     the controller's value rising from below 64 to 64 or more, or a value of 64 or more
//     repeating the previous one (a button that sends presses only; a knob sends only changes).
//   knobs (glide time, vibrato depth, vibrato rate) take every value 0-127 of their controller.
// A control change that a binding claims is the action's alone: the allocator never sees it.
#ifndef STEPCHOIR_HOST_LIVE_STAGE_H
#define STEPCHOIR_HOST_LIVE_STAGE_H

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "core/midi_event.h"

namespace stepchoir {

enum class Action : uint8_t {
  kTransposeUp,      // +1 semitone for notes that start from now (every preset), to +48
  kTransposeDown,    // -1 semitone, to -48
  kOctaveUp,         // +12 semitones
  kOctaveDown,       // -12 semitones
  kGlideTime,        // knob: every channel's glide time (as CC5: 16 ms a step), glide on above 0
  kVibratoDepth,     // knob: every channel's vibrato depth (as the mod wheel, CC1)
  kVibratoRate,      // knob: the vibrato's rate, vibrato_rate_hz(value)
  kPresetNext,       // the next preset of the rig file (wraps)
  kPresetPrevious,   // the previous preset (wraps)
  kSetlistNext,      // the setlist's next item (the main thread steps it)
  kSetlistPrevious,  // the setlist's previous item
  kPanic,            // silences every motor, forgets every note and pedal
  kMuteMotor,        // mutes motor N, or unmutes it when muted (a stage mute outlasts presets)
};
constexpr size_t kActionCount = 13;

// The name the rig file and the console use: "transpose_up", "mute_motor", ...
// Called from: any thread (a table lookup).
const char *action_name(Action a) noexcept;
// The action a name spells, or nothing. Called from: the configuration reader, the learn prompt.
std::optional<Action> parse_action(std::string_view name) noexcept;
// A knob (takes the controller's value) rather than a button.
constexpr bool action_is_knob(Action a) noexcept {
  return a == Action::kGlideTime || a == Action::kVibratoDepth || a == Action::kVibratoRate;
}

// The vibrato rate a knob at value (0-127) sets: 1 Hz to 10 Hz, linear.
constexpr double kVibratoRateMinHz = 1.0, kVibratoRateMaxHz = 10.0;
constexpr double vibrato_rate_hz(uint8_t value) noexcept {
  return kVibratoRateMinHz + (kVibratoRateMaxHz - kVibratoRateMinHz) * (value > 127 ? 127 : value) / 127.0;
}

// One learned controller: a control change number on a channel -> an action.
struct Binding {
  int8_t channel = -1;  // MIDI channel 0-15 (the file says 1-16), -1: any
  uint8_t cc = 0;       // controller number 0-119 (120-127 are channel mode messages)
  Action action = Action::kPanic;
  uint8_t motor = 0;    // kMuteMotor: the pool motor
};

// What one claimed control change asks of the engine.
struct StageAction {
  Action action = Action::kPanic;
  uint8_t value = 127;  // knobs: the controller's value
  uint8_t motor = 0;    // kMuteMotor
};

class ControlMap {
 public:
  static constexpr size_t kMaxBindings = 64;

  // Adds a binding, replacing those on the same controller and channel and those of the same
  // action (mute_motor: and motor): one controller an action. False when the table is full or
  // the binding's controller or channel is out of range.
  // Called from: setup code, the engine thread (a learned controller). Does not allocate.
  bool bind(const Binding &b) noexcept;
  // For a control change a binding claims: true, and *fire says whether its action happens
  // now (*out: what). False for any other event (the allocator's).
  // Called from: the engine thread, for every MIDI event. A walk of the table; does not allocate.
  bool claim(const MidiEvent &e, StageAction *out, bool *fire) noexcept;
  size_t size() const noexcept { return count_; }
  const Binding &at(size_t i) const noexcept { return bindings_[i]; }

 private:
  std::array<Binding, kMaxBindings> bindings_{};
  std::array<uint8_t, kMaxBindings> last_{};  // each binding's previous value (0 at start)
  size_t count_ = 0;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_STAGE_H

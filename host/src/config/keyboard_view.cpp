// keyboard_view.cpp: the rig file's presets and controls for a keyboard that plays only some of
// the pool's motors (see config.h).
#include <algorithm>
#include <string>
#include <vector>

#include "config/config.h"

namespace stepchoir {

namespace {

constexpr const char *kSongMotor = " plays the song: left out of the keyboard's presets and controls";

// Pool index -> its index among the keyboard's motors, or -1.
int keyboard_index(const std::vector<uint8_t> &keyboard, uint8_t motor) {
  const auto it = std::find(keyboard.begin(), keyboard.end(), motor);
  return it == keyboard.end() ? -1 : static_cast<int>(it - keyboard.begin());
}

// The motors of `motors` the keyboard has, as its indexes; each other one told in left_out.
std::vector<uint8_t> keep(const std::vector<uint8_t> &motors, const std::vector<uint8_t> &keyboard,
                          const std::string &where, std::vector<std::string> &left_out) {
  std::vector<uint8_t> out;
  for (uint8_t m : motors) {
    const int k = keyboard_index(keyboard, m);
    if (k >= 0) out.push_back(static_cast<uint8_t>(k));
    else left_out.push_back(where + ": motor " + std::to_string(m) + kSongMotor);
  }
  return out;
}

}  // namespace

LiveConfig keyboard_view(const LiveConfig &config, const std::vector<uint8_t> &keyboard,
                         std::vector<std::string> *left_out) {
  std::vector<std::string> told;
  LiveConfig view = config;
  for (PresetSettings &p : view.presets) {
    p.mute_motors = keep(p.mute_motors, keyboard, p.mute_where, told);
    std::vector<ZoneSettings> zones;
    for (ZoneSettings z : p.zones) {
      z.motors = keep(z.motors, keyboard, z.where, told);
      if (!z.motors.empty()) zones.push_back(z);
    }
    if (!p.zones.empty() && zones.empty()) {
      // Zones that gave the keyboard nothing: it stays silent in this preset (a preset without
      // zones would play every key on every motor).
      told.push_back(p.where + ": preset '" + p.name + "': no zone has a keyboard motor: the keyboard is silent in it");
      p.mute_motors.clear();
      for (size_t k = 0; k < keyboard.size(); ++k) p.mute_motors.push_back(static_cast<uint8_t>(k));
    }
    p.zones = zones;
    std::vector<PresetMotorSettings> motors;
    for (PresetMotorSettings m : p.motors) {
      const int k = keyboard_index(keyboard, m.motor);
      if (k < 0) {
        told.push_back(m.where + ": motor " + std::to_string(m.motor) + kSongMotor);
        continue;
      }
      m.motor = static_cast<uint8_t>(k);
      motors.push_back(m);
    }
    p.motors = motors;
  }
  std::vector<ControlSettings> controls;
  for (ControlSettings c : view.controls) {
    if (c.binding.action == Action::kMuteMotor) {
      const int k = keyboard_index(keyboard, c.binding.motor);
      if (k < 0) {
        told.push_back(c.where + ": motor " + std::to_string(c.binding.motor) + kSongMotor);
        continue;
      }
      c.binding.motor = static_cast<uint8_t>(k);
    }
    controls.push_back(c);
  }
  view.controls = controls;
  if (left_out) *left_out = told;
  return view;
}

}  // namespace stepchoir

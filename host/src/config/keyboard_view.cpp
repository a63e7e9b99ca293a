// keyboard_view.cpp: the rig file's presets and controls for a keyboard that plays only some of
// the pool's motors (see config.h).
#include <optional>
#include <string>
#include <vector>

#include "config/config.h"

namespace stepchoir {

namespace {

constexpr const char *kSongMotor = " plays the song: left out of the keyboard's presets and controls";

// m's index among the keyboard's motors; nullopt, told in left_out, for a motor the song plays.
std::optional<uint8_t> renumber(uint8_t m, const std::vector<size_t> &keyboard, const std::string &where,
                                std::vector<std::string> &left_out) {
  const std::optional<uint8_t> k = keyboard_motor(keyboard, m);
  if (!k) left_out.push_back(where + ": motor " + std::to_string(m) + kSongMotor);
  return k;
}

// The motors of `motors` the keyboard has, as its indexes.
std::vector<uint8_t> keep(const std::vector<uint8_t> &motors, const std::vector<size_t> &keyboard,
                          const std::string &where, std::vector<std::string> &left_out) {
  std::vector<uint8_t> out;
  for (uint8_t m : motors)
    if (const auto k = renumber(m, keyboard, where, left_out)) out.push_back(*k);
  return out;
}

}  // namespace

std::optional<uint8_t> keyboard_motor(const std::vector<size_t> &keyboard, size_t motor) {
  for (size_t i = 0; i < keyboard.size(); ++i)
    if (keyboard[i] == motor) return static_cast<uint8_t>(i);
  return std::nullopt;
}

LiveConfig keyboard_view(const LiveConfig &config, const std::vector<size_t> &keyboard,
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
      const auto k = renumber(m.motor, keyboard, m.where, told);
      if (!k) continue;
      m.motor = *k;
      motors.push_back(m);
    }
    p.motors = motors;
  }
  std::vector<ControlSettings> controls;
  for (ControlSettings c : view.controls) {
    if (c.binding.action == Action::kMuteMotor) {
      const auto k = renumber(c.binding.motor, keyboard, c.where, told);
      if (!k) continue;
      c.binding.motor = *k;
    }
    controls.push_back(c);
  }
  view.controls = controls;
  if (left_out) *left_out = told;
  return view;
}

}  // namespace stepchoir

// presets.h: named presets switched by MIDI program change: what the engine holds of each, and the
// pure selector that tracks each channel's bank select and picks the preset a program change asks
// for. LiveSession applies the pick with Allocator::configure within the same engine cycle.
//
// A program change (0xC0 | channel, program 0-127 on the wire: 1-128 as keyboards show it) on any
// channel selects the preset with that program. A preset that names a bank answers only when the
// channel's bank select (CC0 MSB * 128 + CC32 LSB, both kept per channel until changed, 0 at start)
// is that bank, and is preferred to one that answers to any bank. A program change no preset
// answers to keeps the current preset.
#ifndef STEPCHOIR_HOST_LIVE_PRESETS_H
#define STEPCHOIR_HOST_LIVE_PRESETS_H

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/midi_event.h"
#include "live/allocator.h"

namespace stepchoir {

// One preset as the engine holds it, built before the engine starts (config/config.h
// preset_config makes `config` from the rig file).
struct LivePreset {
  std::string name;       // for displays (read by the main thread; the engine never touches it)
  uint8_t program = 0;    // the program change's value on the wire, 0-127 (shown as 1-128)
  int32_t bank = -1;      // the bank (MSB * 128 + LSB, 0-16383) it answers to; -1: any bank
  AllocatorConfig config;  // the whole allocator configuration of the preset
};

class PresetSelector {
 public:
  // Notes a bank select (CC0, CC32) and, for a program change, returns the index of the preset it
  // selects among presets[0 .. count-1]; -1 for every other event and for a program change no
  // preset answers to.
  // Called from: the engine thread, for every MIDI event before the allocator sees it. A table
  // walk of `count` entries; does not allocate, block or log.
  int select(const MidiEvent &e, const LivePreset *presets, size_t count) noexcept;

  // The bank (MSB * 128 + LSB) channel ch (0-15) has selected. Called from: the engine thread, tests.
  uint16_t bank(uint8_t ch) const noexcept { return static_cast<uint16_t>(msb_[ch & 15] * 128 + lsb_[ch & 15]); }

 private:
  std::array<uint8_t, 16> msb_{}, lsb_{};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_PRESETS_H

// presets.cpp: the program-change preset selector (see presets.h for the rules).
#include "live/presets.h"

namespace stepchoir {

int PresetSelector::select(const MidiEvent &e, const LivePreset *presets, size_t count) noexcept {
  const uint8_t type = e.status & 0xF0, ch = e.status & 0x0F;
  if (e.status >= 0xF0 || e.data1 > 127) return -1;
  if (type == kMidiControlChange && e.data2 <= 127) {
    if (e.data1 == kCcBankSelectMsb) msb_[ch] = e.data2;
    if (e.data1 == kCcBankSelectLsb) lsb_[ch] = e.data2;
    return -1;
  }
  if (type != kMidiProgramChange) return -1;
  const int32_t bank = this->bank(ch);
  int any = -1;
  for (size_t i = 0; i < count; ++i) {
    if (presets[i].program != e.data1) continue;
    if (presets[i].bank == bank) return static_cast<int>(i);
    if (presets[i].bank < 0 && any < 0) any = static_cast<int>(i);
  }
  return any;
}

}  // namespace stepchoir

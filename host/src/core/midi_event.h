// midi_event.h: one MIDI channel message with its arrival time, as the engine passes it around.
#ifndef STEPCHOIR_HOST_MIDI_EVENT_H
#define STEPCHOIR_HOST_MIDI_EVENT_H

#include <cstdint>

namespace stepchoir {

// A complete MIDI message (running status already resolved by whoever parsed the stream).
// Plain data: trivially copyable, no constructor, fits a lock-free queue slot.
struct MidiEvent {
  uint8_t status;          // 0x80-0xEF for channel messages: high nibble = type, low = channel
  uint8_t data1;           // first data byte (note, controller number, bend LSB), 0-127
  uint8_t data2;           // second data byte (velocity, controller value, bend MSB), 0-127
  uint64_t timestamp_us;   // arrival time on the host's monotonic clock, microseconds
};

// Status high nibbles of the channel messages the engine understands.
constexpr uint8_t kMidiNoteOff = 0x80;
constexpr uint8_t kMidiNoteOn = 0x90;
constexpr uint8_t kMidiControlChange = 0xB0;
constexpr uint8_t kMidiProgramChange = 0xC0;
// System messages of a MIDI clock (jam --midi-clock): 24 ticks a quarter note, Start (from the
// top), Continue (from the Song Position Pointer), Stop; the pointer counts sixteenths.
constexpr uint8_t kMidiSongPosition = 0xF2;
constexpr uint8_t kMidiClockTick = 0xF8;
constexpr uint8_t kMidiClockStart = 0xFA;
constexpr uint8_t kMidiClockContinue = 0xFB;
constexpr uint8_t kMidiClockStop = 0xFC;
constexpr uint8_t kMidiChannelPressure = 0xD0;  // aftertouch of the whole channel
constexpr uint8_t kMidiPitchBend = 0xE0;

// Controller numbers (data1 of a control change) the engine understands.
constexpr uint8_t kCcBankSelectMsb = 0;
constexpr uint8_t kCcModWheel = 1;
constexpr uint8_t kCcPortamentoTime = 5;
constexpr uint8_t kCcDataEntryMsb = 6;
constexpr uint8_t kCcBankSelectLsb = 32;
constexpr uint8_t kCcDataEntryLsb = 38;
constexpr uint8_t kCcSustain = 64;
constexpr uint8_t kCcPortamento = 65;
constexpr uint8_t kCcNrpnLsb = 98;
constexpr uint8_t kCcNrpnMsb = 99;
constexpr uint8_t kCcRpnLsb = 100;
constexpr uint8_t kCcRpnMsb = 101;
constexpr uint8_t kCcAllSoundOff = 120;
constexpr uint8_t kCcResetAllControllers = 121;
constexpr uint8_t kCcAllNotesOff = 123;

// Percussion: General MIDI's drum channel (0-based; channel 10 as musicians count), and the
// bank select (CC0) values that make any channel a drum kit (GM2 rhythm bank, XG drum bank) or
// a melodic one again (GM2 melody bank). A bank select takes effect at the channel's next
// program change.
constexpr uint8_t kGmDrumChannel = 9;
constexpr uint8_t kBankGm2Rhythm = 120;
constexpr uint8_t kBankGm2Melody = 121;
constexpr uint8_t kBankXgDrums = 127;

// Whether a channel plays drums after a program change with bank MSB bank. Called from: the
// MIDI file reader and the live allocator.
constexpr bool percussion_bank(uint8_t channel, uint8_t bank) {
  return bank == kBankGm2Rhythm || bank == kBankXgDrums ? true
         : bank == kBankGm2Melody                     ? false
                                                      : channel == kGmDrumChannel;
}

// Builders, mostly for tests and tools. channel is 0-15.
constexpr MidiEvent note_on(uint8_t channel, uint8_t note, uint8_t velocity, uint64_t t_us = 0) {
  return MidiEvent{static_cast<uint8_t>(kMidiNoteOn | (channel & 0x0F)), note, velocity, t_us};
}
constexpr MidiEvent note_off(uint8_t channel, uint8_t note, uint8_t velocity = 64, uint64_t t_us = 0) {
  return MidiEvent{static_cast<uint8_t>(kMidiNoteOff | (channel & 0x0F)), note, velocity, t_us};
}
constexpr MidiEvent control_change(uint8_t channel, uint8_t controller, uint8_t value, uint64_t t_us = 0) {
  return MidiEvent{static_cast<uint8_t>(kMidiControlChange | (channel & 0x0F)), controller, value, t_us};
}
// value is the 14-bit bend, 0-16383, centre 8192.
constexpr MidiEvent pitch_bend(uint8_t channel, uint16_t value, uint64_t t_us = 0) {
  return MidiEvent{static_cast<uint8_t>(kMidiPitchBend | (channel & 0x0F)),
                   static_cast<uint8_t>(value & 0x7F), static_cast<uint8_t>((value >> 7) & 0x7F), t_us};
}

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_MIDI_EVENT_H

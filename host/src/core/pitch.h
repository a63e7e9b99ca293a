// pitch.h: frequencies and notes -> periods in CPU ticks with 8 fractional bits (pure).
#ifndef STEPCHOIR_HOST_PITCH_H
#define STEPCHOIR_HOST_PITCH_H

#include <cmath>
#include <cstdint>

#include "stepchoir_protocol.h"

namespace stepchoir {

// Standard tuning reference: A4 (MIDI 69) in Hz.
constexpr double kA4Hz = 440.0;

// Frequency of a MIDI note number (fractional allowed) for a given A4 reference.
inline double note_hz(double midi_note, double a4_hz = kA4Hz) {
  return a4_hz * std::exp2((midi_note - 69.0) / 12.0);
}

// Period in ticks q8 for freq_hz on a board clocked at f_cpu_hz (a measured rate may be
// fractional: the player corrects pitch for a crystal that is off); 0 for freq_hz <= 0.
// Returns 0 too when the period does not fit the 28-bit field (below ~15 Hz at 16 MHz).
inline uint32_t hz_to_period_q8(double freq_hz, double f_cpu_hz) {
  if (!(freq_hz > 0)) return sc::kPeriodSilent;
  const double q8 = std::round(f_cpu_hz * 256.0 / freq_hz);
  if (q8 > sc::kPeriodQ8Max || q8 < 1) return sc::kPeriodSilent;
  return static_cast<uint32_t>(q8);
}

// Frequency in Hz that a period in ticks q8 plays on a board clocked at f_cpu_hz.
inline double period_q8_to_hz(uint32_t period_q8, uint32_t f_cpu_hz) {
  return period_q8 ? f_cpu_hz * 256.0 / period_q8 : 0.0;
}

// Cents from b to a (positive when a is higher).
inline double cents(double a_hz, double b_hz) { return 1200.0 * std::log2(a_hz / b_hz); }

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PITCH_H

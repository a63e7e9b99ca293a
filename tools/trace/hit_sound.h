// hit_sound.h: percussive hits (short bursts of steps on one motor) as a listener hears them in
// the rendered audio: pitch from the step rate, length and level from the audio's envelope.
// Called by the drum voice's end-to-end test and stepchoir-bench-drums.
#ifndef STEPCHOIR_TOOLS_TRACE_HIT_SOUND_H
#define STEPCHOIR_TOOLS_TRACE_HIT_SOUND_H

#include <cstddef>
#include <cstdint>
#include <vector>

#include "trace.h"

namespace sc {
namespace trace {

struct HitSound {
  double start_s = 0;    // real seconds of the burst's first step
  size_t steps = 0;      // steps in the burst
  double step_hz = 0;    // step rate (board time): the pitch a listener hears
  double midi_note = 0;  // midi_from_hz(step_hz), fractional
  double heard_s = 0;    // how long the 5 ms RMS envelope stays within 20 dB of its peak
  double peak_dbfs = 0;  // the envelope's peak, dB relative to 16-bit full scale
};

// Splits motor's steps into bursts (a step more than gap_s after the last starts a new one) and
// measures each in samples (render_audio of the same trace, at rate_hz), up to the next burst
// or max_window_s after its start.
std::vector<HitSound> measure_hits(const Trace& trace, int motor, const std::vector<int16_t>& samples,
                                   int rate_hz, double gap_s = 0.1, double max_window_s = 0.5);

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TOOLS_TRACE_HIT_SOUND_H

// render.h: turns a trace into sound (16-bit mono WAV) and a picture (PNG piano roll).
#ifndef STEPCHOIR_TRACE_RENDER_H
#define STEPCHOIR_TRACE_RENDER_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis.h"
#include "trace.h"

namespace sc {
namespace trace {

constexpr int kDefaultSampleRateHz = 44100;
constexpr int kDefaultRollWidthPx = 1400;
constexpr int kDefaultRollHeightPx = 600;
constexpr size_t kWavHeaderBytes = 44;  // canonical RIFF/WAVE header with one fmt and one data chunk

// How the audio is synthesised.
struct AudioOptions {
  int sample_rate_hz = kDefaultSampleRateHz;
  double peak_dbfs = -1.0;          // the loudest sample after normalising
  double resonator_base_hz = 2000;  // motor 0 rings here; each further motor a bit higher
  double resonator_decay_s = 0.002; // time for a ring to fall by 1/e
};

// Number of samples rendered for a trace: ceil(real end time * rate).
size_t audio_length_samples(const Trace& trace, int sample_rate_hz);

// Ringing frequency of a motor's resonator (distinct per motor, below Nyquist).
double resonator_hz(const AudioOptions& options, int motor);

// Synthesises the trace: every STEP rise excites its motor's damped resonator at its real
// time; the mix is normalised to options.peak_dbfs (silence stays all zero).
std::vector<int16_t> render_audio(const Trace& trace, const AudioOptions& options = AudioOptions());

// Writes 16-bit mono PCM samples as a WAV file. Throws std::runtime_error on I/O failure.
void write_wav(const std::string& path, const std::vector<int16_t>& samples, int sample_rate_hz);

// Reads a WAV file as write_wav writes it (canonical header, 16-bit mono PCM); sets *sample_rate_hz.
// Called by the tests and benchmarks that listen to a render. Throws std::runtime_error naming
// the file and what differs.
std::vector<int16_t> read_wav(const std::string& path, int* sample_rate_hz);

// An 8-bit RGB picture, rows top to bottom.
struct Image {
  int width_px = 0;
  int height_px = 0;
  std::vector<uint8_t> rgb;  // width_px * height_px * 3 bytes
};

// An RGB colour.
struct Rgb {
  uint8_t r, g, b;
};

// The colour a motor's notes have in the piano roll (distinct for the first ten motors).
Rgb motor_rgb(int motor);

// How the piano roll is drawn.
struct RollOptions {
  int width_px = kDefaultRollWidthPx;
  int height_px = kDefaultRollHeightPx;
  SegmentOptions segments;  // how steps become note bars
};

// Draws a piano roll: x = real time, y = MIDI pitch, one colour per motor, a bar per note,
// a line at every C, a time grid, a tick at every reversal.
Image render_piano_roll(const Trace& trace, const RollOptions& options = RollOptions());

// Writes an RGB image as PNG with libpng. Throws std::runtime_error on failure.
void write_png(const std::string& path, const Image& image);

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_RENDER_H

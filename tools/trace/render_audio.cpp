// render_audio.cpp: WAV synthesis (a damped resonator per motor) and the WAV file writer (see render.h).
#include "render.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace sc {
namespace trace {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInt16FullScale = 32767.0;
constexpr double kDbPerAmplitudeDecade = 20.0;
constexpr double kResonatorSpread = 1.25;      // each motor rings this much higher than the last
constexpr double kMaxResonatorFraction = 0.4;  // of the sample rate: stay well below Nyquist
constexpr double kMaxAudioSeconds = 3600;     // longer traces would need gigabytes of samples
constexpr uint16_t kWavFormatPcm = 1;
constexpr uint16_t kWavChannels = 1;
constexpr uint16_t kWavBitsPerSample = 16;
constexpr uint32_t kWavBytesPerSample = kWavBitsPerSample / 8;
constexpr uint32_t kWavFmtChunkBytes = 16;

}  // namespace

size_t audio_length_samples(const Trace& trace, int sample_rate_hz) {
  if (sample_rate_hz <= 0 || !(trace.f_cpu_hz > 0)) return 0;
  return size_t(std::ceil(trace.real_seconds(trace.end_cycle) * double(sample_rate_hz)));
}

double resonator_hz(const AudioOptions& options, int motor) {
  double hz = options.resonator_base_hz * std::pow(kResonatorSpread, double(motor));
  return std::min(hz, kMaxResonatorFraction * double(options.sample_rate_hz));
}

std::vector<int16_t> render_audio(const Trace& trace, const AudioOptions& options) {
  if (options.sample_rate_hz <= 0) throw std::invalid_argument("render_audio: sample rate must be > 0");
  if (!(options.resonator_decay_s > 0)) throw std::invalid_argument("render_audio: decay must be > 0");
  const size_t n = audio_length_samples(trace, options.sample_rate_hz);
  const double rate_hz = double(options.sample_rate_hz);
  if (double(n) > kMaxAudioSeconds * rate_hz)
    throw std::runtime_error("trace lasts " + std::to_string(trace.real_seconds(trace.end_cycle)) +
                             " s; audio is limited to " + std::to_string(int(kMaxAudioSeconds)) + " s");
  std::vector<float> mix(n, 0.0f);
  for (int m = 0; m < int(trace.motor.size()); ++m) {
    const std::vector<Step>& steps = trace.motor[size_t(m)].steps;
    if (steps.empty()) continue;
    // two-pole resonator: impulse response r^k sin((k+1) w) / sin w, scaled to peak ~1
    const double w = 2.0 * kPi * resonator_hz(options, m) / rate_hz;
    const double r = std::exp(-1.0 / (options.resonator_decay_s * rate_hz));
    const double a1 = 2.0 * r * std::cos(w), a2 = -r * r, gain = std::sin(w);
    double y1 = 0, y2 = 0;
    double carry = 0;  // the part of the last impulse that falls on the next sample
    size_t next_step = 0;
    for (size_t k = 0; k < n; ++k) {
      double x = carry;
      carry = 0;
      // split each impulse over two samples: sub-sample timing keeps the pitch clean
      for (; next_step < steps.size(); ++next_step) {
        double at_samples = trace.real_seconds(steps[next_step].rise_cycle) * rate_hz;
        if (at_samples >= double(k + 1)) break;
        double frac = std::max(0.0, at_samples - double(k));
        x += 1.0 - frac;
        carry += frac;
      }
      double y = gain * x + a1 * y1 + a2 * y2;
      y2 = y1;
      y1 = y;
      mix[k] += float(y);
    }
  }
  double peak = 0;
  for (float v : mix) peak = std::max(peak, double(std::fabs(v)));
  std::vector<int16_t> out(n, 0);
  if (peak <= 0) return out;
  const double scale = kInt16FullScale * std::pow(10.0, options.peak_dbfs / kDbPerAmplitudeDecade) / peak;
  for (size_t k = 0; k < n; ++k) {
    double v = std::round(double(mix[k]) * scale);
    out[k] = int16_t(std::max(-kInt16FullScale, std::min(kInt16FullScale, v)));
  }
  return out;
}

namespace {

// Appends a little-endian 16-bit value.
void put_u16(std::string& out, uint16_t v) {
  out += char(v & 0xff);
  out += char(v >> 8);
}

// Appends a little-endian 32-bit value.
void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out += char((v >> (8 * i)) & 0xff);
}

// A little-endian 16- or 32-bit value at offset.
uint32_t get_le(const std::string& in, size_t offset, int bytes) {
  uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | uint8_t(in[offset + size_t(i)]);
  return v;
}

}  // namespace

void write_wav(const std::string& path, const std::vector<int16_t>& samples, int sample_rate_hz) {
  if (sample_rate_hz <= 0) throw std::invalid_argument("write_wav: sample rate must be > 0");
  const uint64_t data_bytes = uint64_t(samples.size()) * kWavBytesPerSample;
  if (data_bytes + kWavHeaderBytes > 0xffffffffull) throw std::runtime_error(path + ": too long for WAV");
  std::string out;
  out.reserve(kWavHeaderBytes + size_t(data_bytes));
  out += "RIFF";
  put_u32(out, uint32_t(kWavHeaderBytes - 8 + data_bytes));
  out += "WAVE";
  out += "fmt ";
  put_u32(out, kWavFmtChunkBytes);
  put_u16(out, kWavFormatPcm);
  put_u16(out, kWavChannels);
  put_u32(out, uint32_t(sample_rate_hz));
  put_u32(out, uint32_t(sample_rate_hz) * kWavChannels * kWavBytesPerSample);  // byte rate
  put_u16(out, uint16_t(kWavChannels * kWavBytesPerSample));                  // block align
  put_u16(out, kWavBitsPerSample);
  out += "data";
  put_u32(out, uint32_t(data_bytes));
  for (int16_t s : samples) put_u16(out, uint16_t(s));
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
  file.write(out.data(), std::streamsize(out.size()));
  file.close();
  if (!file) throw std::runtime_error(path + ": write failed");
}

std::vector<int16_t> read_wav(const std::string& path, int* sample_rate_hz) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  const std::string in((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (in.size() < kWavHeaderBytes || in.compare(0, 4, "RIFF") != 0 || in.compare(8, 4, "WAVE") != 0 ||
      in.compare(12, 4, "fmt ") != 0 || in.compare(36, 4, "data") != 0)
    throw std::runtime_error(path + ": not a canonical WAV file (RIFF, WAVE, fmt, data at bytes 0, 8, 12, 36)");
  if (get_le(in, 20, 2) != kWavFormatPcm || get_le(in, 22, 2) != kWavChannels ||
      get_le(in, 34, 2) != kWavBitsPerSample)
    throw std::runtime_error(path + ": expected 16-bit mono PCM (bytes 20-35)");
  const uint32_t data_bytes = get_le(in, 40, 4);
  if (data_bytes % kWavBytesPerSample != 0 || data_bytes > in.size() - kWavHeaderBytes)
    throw std::runtime_error(path + ": data chunk of " + std::to_string(data_bytes) + " bytes, file has " +
                             std::to_string(in.size() - kWavHeaderBytes));
  if (sample_rate_hz) *sample_rate_hz = int(get_le(in, 24, 4));
  std::vector<int16_t> samples(data_bytes / kWavBytesPerSample);
  for (size_t k = 0; k < samples.size(); ++k) samples[k] = int16_t(get_le(in, kWavHeaderBytes + 2 * k, 2));
  return samples;
}

}  // namespace trace
}  // namespace sc

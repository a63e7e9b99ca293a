// hit_sound.cpp: percussive hits measured from the trace and its rendered audio (see hit_sound.h).
#include "hit_sound.h"

#include <algorithm>
#include <cmath>

#include "analysis.h"

namespace sc {
namespace trace {
namespace {

constexpr double kEnvelopeS = 0.005;     // RMS window of the envelope
constexpr double kHeardFraction = 0.1;   // -20 dB of the peak envelope
constexpr double kLeadS = 0.002;         // the window opens this long before the first step
constexpr double kInt16FullScale = 32767.0;

// One burst's steps: [first, last] indices into the motor's steps.
struct Burst {
  size_t first, last;
};

}  // namespace

std::vector<HitSound> measure_hits(const Trace& trace, int motor, const std::vector<int16_t>& samples,
                                   int rate_hz, double gap_s, double max_window_s) {
  std::vector<HitSound> hits;
  if (motor < 0 || size_t(motor) >= trace.motor.size() || rate_hz <= 0) return hits;
  const std::vector<Step>& steps = trace.motor[size_t(motor)].steps;
  std::vector<Burst> bursts;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (i > 0 && trace.real_seconds(steps[i].rise_cycle - steps[i - 1].rise_cycle) <= gap_s) {
      bursts.back().last = i;
    } else {
      bursts.push_back({i, i});
    }
  }
  const size_t window = std::max<size_t>(1, size_t(kEnvelopeS * rate_hz));
  for (size_t b = 0; b < bursts.size(); ++b) {
    HitSound h;
    h.start_s = trace.real_seconds(steps[bursts[b].first].rise_cycle);
    h.steps = bursts[b].last - bursts[b].first + 1;
    if (h.steps > 1) {
      const uint64_t span = steps[bursts[b].last].rise_cycle - steps[bursts[b].first].rise_cycle;
      h.step_hz = trace.f_cpu_hz * double(h.steps - 1) / double(span);
      h.midi_note = midi_from_hz(h.step_hz);
    }
    double end_s = h.start_s + max_window_s;
    if (b + 1 < bursts.size()) end_s = std::min(end_s, trace.real_seconds(steps[bursts[b + 1].first].rise_cycle) - kLeadS);
    const size_t begin = size_t(std::max(0.0, (h.start_s - kLeadS) * rate_hz));
    const size_t end = std::min(samples.size(), size_t(std::max(0.0, end_s * rate_hz)));
    if (end <= begin + window) {
      hits.push_back(h);
      continue;
    }
    // Running RMS over the window, centred.
    std::vector<double> envelope(end - begin, 0.0);
    double sum = 0;
    for (size_t k = begin; k < end; ++k) {
      sum += double(samples[k]) * samples[k];
      if (k >= begin + window) sum -= double(samples[k - window]) * samples[k - window];
      const size_t at = k - begin >= window / 2 ? k - begin - window / 2 : 0;
      envelope[at] = std::sqrt(std::max(0.0, sum) / double(window));
    }
    const double peak = *std::max_element(envelope.begin(), envelope.end());
    if (peak > 0) {
      h.peak_dbfs = 20.0 * std::log10(peak / kInt16FullScale);
      size_t first = envelope.size(), last = 0;
      for (size_t k = 0; k < envelope.size(); ++k) {
        if (envelope[k] < kHeardFraction * peak) continue;
        first = std::min(first, k);
        last = k;
      }
      h.heard_s = double(last - first + 1) / rate_hz;
    }
    hits.push_back(h);
  }
  return hits;
}

}  // namespace trace
}  // namespace sc

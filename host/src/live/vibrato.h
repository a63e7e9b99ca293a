// vibrato.h: the vibrato the allocator adds to a sounding note: a sine in pitch, its depth
// linear in the channel's mod wheel (CC1) or, when asked, its aftertouch, faded in after the
// note starts. Pure; called from: Allocator::retune on the engine thread (no allocation).
#ifndef STEPCHOIR_HOST_LIVE_VIBRATO_H
#define STEPCHOIR_HOST_LIVE_VIBRATO_H

#include <cmath>
#include <cstdint>

namespace stepchoir {

struct VibratoConfig {
  double rate_hz = 5.5;       // the sine's rate
  double depth_cents = 50.0;  // peak deviation at controller 127 (linear below)
  double fade_ms = 150.0;     // the depth rises linearly over this long after the note starts
  bool aftertouch = false;    // channel pressure sets the depth too (the larger of the two)
};

// How often the engine refreshes vibrating motors' periods, us (100 a second: about 18 updates
// a cycle at 5.5 Hz, 8 bytes each, well inside the link budget for five motors).
constexpr uint64_t kVibratoTickUs = 10000;

// The pitch offset (cents) of a note age_us after it started, with the controller at amount
// (0-127). The phase starts at the note's start, so a held note's vibrato is continuous.
inline double vibrato_cents(const VibratoConfig &c, uint8_t amount, uint64_t age_us) noexcept {
  if (amount == 0 || !(c.depth_cents > 0) || !(c.rate_hz > 0)) return 0.0;
  const double t = static_cast<double>(age_us) / 1e6;
  const double fade = c.fade_ms > 0 ? std::fmin(1.0, t * 1000.0 / c.fade_ms) : 1.0;
  return c.depth_cents * amount / 127.0 * fade * std::sin(2.0 * M_PI * c.rate_hz * t);
}

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_VIBRATO_H

// glide.h: portamento. With a channel's glide on (CC65 >= 64), a motor's new note slides from the
// note it played before at an even rate in cents over the glide time (CC5: 16 ms a step, 0 to
// 2,032 ms), and then plays exactly its own pitch. Pure; called from: the Allocator on the
// engine thread (no allocation).
#ifndef STEPCHOIR_HOST_LIVE_GLIDE_H
#define STEPCHOIR_HOST_LIVE_GLIDE_H

#include <cstdint>

namespace stepchoir {

// Glide time per step of CC5, us.
constexpr uint64_t kGlideUsPerStep = 16000;
// The longest glide time, ms (CC5 at 127).
constexpr uint16_t kGlideMaxMs = 2032;

// How every channel's glide starts (a preset's [presets.glide], the file's [glide]): its time
// as CC5 would set it, but to the ms, and glide on without CC65. CC5 and CC65 change it as
// usual; reset-all-controllers turns glide back to `on`.
struct GlideConfig {
  uint16_t time_ms = 0;  // 0 .. kGlideMaxMs
  bool on = false;       // glide on from the start, as if CC65 were down
};
// A poly motor that fell silent this recently still glides into its next note (a player's
// detached legato), us.
constexpr uint64_t kGlideAfterSilenceUs = 100000;

// One motor's slide: from `from` semitones (the note it played) to its new note, starting at
// start_us, lasting duration_us.
struct Glide {
  double from = 0;
  uint64_t start_us = 0, duration_us = 0;

  bool active(uint64_t now_us) const noexcept { return duration_us > 0 && now_us < start_us + duration_us; }
  // The semitones to add to the target note `to` at now_us: (from - to) shrinking linearly to
  // 0, exactly 0 from the end on.
  double offset(double to, uint64_t now_us) const noexcept {
    if (!active(now_us)) return 0.0;
    const double left = 1.0 - static_cast<double>(now_us - start_us) / static_cast<double>(duration_us);
    return (from - to) * left;
  }
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_GLIDE_H

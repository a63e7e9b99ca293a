// allocator_stage.cpp: the Allocator's stage controls, the performer's transpose, mutes and knobs
// (live/stage.h actions; the rules are in allocator.h).
#include <cmath>

#include "live/allocator.h"

namespace stepchoir {

void Allocator::set_stage_transpose(int semitones) noexcept {
  stage_transpose_ = semitones < -48 ? -48 : semitones > 48 ? 48 : semitones;
}

void Allocator::set_stage_mutes(uint32_t mask) noexcept {
  const uint32_t pool = config_.motor_count >= 32 ? 0xFFFFFFFFu : (1u << config_.motor_count) - 1;
  mask &= pool;
  const uint32_t changed = mask ^ stage_mutes_;
  stage_mutes_ = mask;
  for (size_t m = 0; m < config_.motor_count; ++m) {
    if (!(changed >> m & 1)) continue;
    if (is_poly() && (mask >> m & 1)) {
      hand_over(m);  // a doubler of its note, if any, carries the note on
      release(m);
    } else {
      retune(m);  // kMono/kChannel: silent while muted, the channel's note again when not
    }
  }
}

void Allocator::control_all(uint8_t cc, uint8_t value) noexcept {
  if (cc >= kCcAllSoundOff || value > 127) return;
  for (uint8_t ch = 0; ch < 16; ++ch) control_change(ch, cc, value);
}

void Allocator::set_vibrato_rate(double hz) noexcept {
  if (!(hz > 0 && hz <= 20)) return;
  const double old = config_.vibrato.rate_hz;
  config_.vibrato.rate_hz = hz;
  if (!(old > 0)) return;
  // Each note's phase is rate * age: moving its onset keeps rate * age where it is.
  for (size_t m = 0; m < config_.motor_count; ++m) {
    Voice &v = voices_[m];
    if (!v.active || now_us_ <= v.onset_us) continue;
    const double age_us = static_cast<double>(now_us_ - v.onset_us) * old / hz;
    v.onset_us = now_us_ - static_cast<uint64_t>(std::llround(age_us < static_cast<double>(now_us_) ? age_us : 0.0));
  }
}

}  // namespace stepchoir

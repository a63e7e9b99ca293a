// coalescer.cpp: Coalescer, the latest state per motor, silences kept.
#include "live/coalescer.h"

namespace stepchoir {

void Coalescer::add(const MotorUpdate &u) noexcept {
  if (u.motor >= kMaxMotors) return;
  Slot &s = slots_[u.motor];
  if (u.period_q8 == sc::kPeriodSilent) {
    if (s.dirty && s.latest != sc::kPeriodSilent) ++coalesced_;  // a note that never went out
    s.latest = sc::kPeriodSilent;
    s.latest_us = u.event_us;
    s.silence_first = false;  // the silence is now the latest state itself
    s.dirty = s.sent != sc::kPeriodSilent;
    return;
  }
  if (s.dirty && s.latest == sc::kPeriodSilent && s.sent != sc::kPeriodSilent) {
    s.silence_first = true;  // keep the silence: the new note must strike again
    s.silence_us = s.latest_us;
  } else if (s.dirty) {
    ++coalesced_;
  }
  s.latest = u.period_q8;
  s.latest_us = u.event_us;
  s.dirty = true;
}

size_t Coalescer::take_silences(sc::PeriodEntry *out, uint64_t *event_us) noexcept {
  size_t n = 0;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (!s.silence_first) continue;
    if (event_us) event_us[n] = s.silence_us;
    out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), sc::kPeriodSilent};
    s.sent = sc::kPeriodSilent;
    s.silence_first = false;
  }
  return n;
}

size_t Coalescer::take_latest(sc::PeriodEntry *out, uint64_t *event_us) noexcept {
  size_t n = 0;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (!s.dirty) continue;
    if (s.silence_first) {  // take_silences was skipped: keep the order anyway
      if (event_us) event_us[n] = s.silence_us;
      out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), sc::kPeriodSilent};
      s.silence_first = false;
      continue;
    }
    if (event_us) event_us[n] = s.latest_us;
    out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), s.latest};
    s.sent = s.latest;
    s.dirty = false;
  }
  return n;
}

void Coalescer::refresh(size_t motor_count) noexcept {
  for (size_t m = 0; m < motor_count && m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (s.dirty || s.silence_first) continue;  // going out anyway
    s.dirty = true;
    s.latest_us = 0;
  }
}

void Coalescer::refresh(const uint8_t *motors, size_t n) noexcept {
  for (size_t i = 0; i < n; ++i) {
    if (motors[i] >= kMaxMotors) continue;
    Slot &s = slots_[motors[i]];
    if (s.dirty || s.silence_first) continue;
    s.dirty = true;
    s.latest_us = 0;
  }
}

void Coalescer::board_restarted() noexcept {
  for (Slot &s : slots_) {
    s.sent = sc::kPeriodSilent;
    s.silence_first = false;
    s.dirty = s.latest != sc::kPeriodSilent;
  }
}

bool Coalescer::pending() const noexcept {
  for (const Slot &s : slots_)
    if (s.dirty || s.silence_first) return true;
  return false;
}

}  // namespace stepchoir

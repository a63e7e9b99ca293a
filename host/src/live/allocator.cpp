// allocator.cpp: the Allocator's frame: configuration, the event dispatch, output, queries, and
// the pitch of each motor (see allocator.h for the rules; allocator_notes.cpp places notes,
// allocator_controllers.cpp applies controllers, pedals, vibrato and glide).
#include "live/allocator.h"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace stepchoir {

const char *Allocator::validate(const AllocatorConfig &c) noexcept {
  if (c.motor_count < 1 || c.motor_count > kMaxMotors) return "motor_count must be 1 to 32";
  if (!(std::isfinite(c.a4_hz) && c.a4_hz > 0)) return "a4_hz must be a positive frequency";
  if (c.policy != Policy::kPoly && c.policy != Policy::kChannel && c.policy != Policy::kMono)
    return "unknown policy";
  if (c.priority != Priority::kOldest && c.priority != Priority::kLowest &&
      c.priority != Priority::kHighest)
    return "unknown priority";
  for (size_t m = 0; m < c.motor_count; ++m) {
    const MotorConfig &mc = c.motors[m];
    if (mc.f_cpu_hz == 0) return "a motor's f_cpu_hz is 0";
    if (mc.highest_note > 127 || mc.lowest_note > mc.highest_note)
      return "a motor's range is not lowest <= highest <= 127";
    if (!std::isfinite(mc.tuning_cents)) return "a motor's tuning is not a number";
    if (c.mono_channel[m] < -1 || c.mono_channel[m] > 15) return "mono_channel must be -1 to 15";
  }
  const uint32_t pool = c.motor_count >= 32 ? 0xFFFFFFFFu : (1u << c.motor_count) - 1;
  if (c.transpose < -48 || c.transpose > 48) return "transpose must be -48 to 48";
  if (c.bend_range > 127) return "bend_range must be 0 to 127";
  if (c.glide.time_ms > kGlideMaxMs) return "the glide time must be 0 to 2032 ms";
  if (c.muted_motors & ~pool) return "a muted motor is not in the pool";
  if (c.zone_count > AllocatorConfig::kMaxZones) return "at most 16 zones";
  if (c.zone_count > 0 && c.policy != Policy::kPoly) return "zones need policy poly";
  for (size_t z = 0; z < c.zone_count; ++z) {
    const Zone &zone = c.zones[z];
    if (zone.highest > 127 || zone.lowest > zone.highest) return "a zone's keys are not lowest <= highest <= 127";
    if (zone.channel < -1 || zone.channel > 15) return "a zone's channel must be -1 to 15";
    if (zone.motors == 0) return "a zone has no motor";
    if (zone.motors & ~pool) return "a zone's motor is not in the pool";
  }
  return nullptr;
}

Allocator::Allocator(const AllocatorConfig &config) {
  if (const char *why = validate(config)) throw std::invalid_argument(why);
  config_ = config;
  reset_state();
  period_.fill(sc::kPeriodSilent);
  reported_.fill(sc::kPeriodSilent);  // the boards start silent
}

bool Allocator::configure(const AllocatorConfig &config) noexcept {
  if (validate(config)) return false;
  config_ = config;
  reset_state();
  period_.fill(sc::kPeriodSilent);  // reported_ stays: flush() silences what was sounding
  return true;
}

// Forgets every note and resets every channel to the configuration's bend range and glide;
// derives each motor's owning channel (none for a muted motor).
void Allocator::reset_state() noexcept {
  voices_.fill(Voice{});
  glide_.fill(Glide{});
  last_pitch_.fill(0.0);
  silent_us_.fill(0);
  channels_.fill(Channel{});
  for (Channel &c : channels_) {
    c.range_semitones = config_.bend_range;
    c.glide = config_.glide.on;
    c.glide_us = config_.glide.time_ms * uint32_t{1000};
  }
  channels_[kGmDrumChannel].percussion = true;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    owner_[m] = kNone;
    if (m >= config_.motor_count || (config_.muted_motors >> m & 1)) continue;
    if (config_.policy == Policy::kChannel && m < 16) owner_[m] = static_cast<uint8_t>(m);
    if (config_.policy == Policy::kMono && config_.mono_channel[m] >= 0)
      owner_[m] = static_cast<uint8_t>(config_.mono_channel[m]);
  }
}

size_t Allocator::handle(const MidiEvent &e, sc::PeriodEntry *out, size_t max_out) noexcept {
  const uint8_t type = e.status & 0xF0, ch = e.status & 0x0F;
  if (e.timestamp_us > now_us_) now_us_ = e.timestamp_us;
  const bool valid = e.status >= 0x80 && e.status < 0xF0 && e.data1 < 128 && e.data2 < 128;
  if (valid) {
    switch (type) {
      case kMidiNoteOff: note_off(ch, e.data1); break;
      case kMidiNoteOn:
        if (e.data2 == 0) note_off(ch, e.data1);
        else if (!channels_[ch].percussion || config_.sing_percussion) note_on(ch, e.data1, e.data2);
        break;
      case kMidiProgramChange: channels_[ch].percussion = percussion_bank(ch, channels_[ch].bank); break;
      case kMidiControlChange: control_change(ch, e.data1, e.data2); break;
      case kMidiPitchBend:
        channels_[ch].bend = static_cast<uint16_t>(e.data1 | (e.data2 << 7));
        retune_channel(ch);
        break;
      case kMidiChannelPressure:
        channels_[ch].pressure = e.data1;
        if (config_.vibrato.aftertouch) retune_channel(ch);
        break;
      default: break;  // polyphonic aftertouch: nothing to do
    }
  }
  return flush(out, max_out);
}

size_t Allocator::flush(sc::PeriodEntry *out, size_t max_out) noexcept {
  size_t n = 0;
  for (size_t m = 0; m < kMaxMotors && n < max_out; ++m) {
    if (period_[m] == reported_[m]) continue;
    out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), period_[m]};
    reported_[m] = period_[m];
  }
  return n;
}

size_t Allocator::panic(sc::PeriodEntry *out, size_t max_out) noexcept {
  voices_.fill(Voice{});
  for (Channel &c : channels_) {
    c.pedal = false;
    c.depth = 0;
    c.key_up.reset();
  }
  period_.fill(sc::kPeriodSilent);
  for (size_t m = 0; m < config_.motor_count; ++m) reported_[m] = kUnreported;
  return flush(out, max_out);
}

void Allocator::set_a4_hz(double a4_hz) noexcept {
  if (!(std::isfinite(a4_hz) && a4_hz > 0)) return;
  config_.a4_hz = a4_hz;
  for (size_t m = 0; m < config_.motor_count; ++m) retune(m);
}

MotorState Allocator::motor(size_t m) const noexcept {
  MotorState s;
  if (m >= config_.motor_count) return s;
  const Voice &v = voices_[m];
  s.sounding = v.active;
  if (v.active) {
    s.channel = v.channel;
    s.note = v.note;
    s.played_note = v.played;
    s.held = v.held;
    s.sustained = v.sustained;
    s.doubling = v.doubler;
  }
  s.period_q8 = period_[m];
  return s;
}

double Allocator::bend_semitones(uint8_t ch) const noexcept {
  if (ch > 15) return 0.0;
  return (channels_[ch].bend - double{kBendCentre}) / kBendCentre * bend_range_semitones(ch);
}

double Allocator::bend_range_semitones(uint8_t ch) const noexcept {
  if (ch > 15) return 0.0;
  return channels_[ch].range_semitones + channels_[ch].range_cents / 100.0;
}

bool Allocator::sustain(uint8_t ch) const noexcept { return ch <= 15 && channels_[ch].pedal; }

bool Allocator::resolve(size_t m, uint8_t note, uint8_t *played, int *octaves) const noexcept {
  return resolve_note(config_.motors[m], note, played, octaves, config_.transpose + stage_transpose_);
}

bool resolve_note(const MotorConfig &mc, uint8_t note, uint8_t *played, int *octaves, int transpose) noexcept {
  const int lo = mc.lowest_note, hi = mc.highest_note;
  const int want = note + mc.transpose + transpose;
  // Nearest octave inside the range: how far the note must move to get in, if it is out.
  int base = want;
  while (base < lo) base += 12;
  while (base > hi) base -= 12;
  if (base < lo) return false;  // the range is narrower than an octave and misses this pitch
  // From there, the nearest unmuted octave, preferring the lower at equal distance.
  for (int step = 0; step <= 10; ++step) {
    for (int candidate : {base - 12 * step, base + 12 * step}) {
      if (candidate < lo || candidate > hi || mc.muted[static_cast<size_t>(candidate)]) continue;
      *played = static_cast<uint8_t>(candidate);
      *octaves = std::abs(candidate - want) / 12;
      return true;
    }
  }
  return false;
}

void Allocator::release(size_t m) noexcept {
  if (voices_[m].active) silent_us_[m] = now_us_ ? now_us_ : 1;
  voices_[m] = Voice{};
  glide_[m] = Glide{};
  period_[m] = sc::kPeriodSilent;
}

void Allocator::retune(size_t m) noexcept {
  const Voice &v = voices_[m];
  if (!v.active || (stage_mutes_ >> m & 1)) {
    period_[m] = sc::kPeriodSilent;
    return;
  }
  const MotorConfig &mc = config_.motors[m];
  const uint64_t age_us = now_us_ > v.onset_us ? now_us_ - v.onset_us : 0;
  last_pitch_[m] = v.played;
  silent_us_[m] = 0;
  double pitch = v.played + glide_[m].offset(v.played, now_us_) + bend_semitones(v.channel) +
                 mc.tuning_cents / 100.0 + vibrato_cents(config_.vibrato, vibrato_amount(v.channel), age_us) / 100.0;
  // A bend or tuning may push the note past what a board plays (sc::kPeriodQ8Min and Max):
  // fold it by octaves, as the range folding does, rather than have the board refuse the frame.
  uint32_t period = hz_to_period_q8(note_hz(pitch, config_.a4_hz), mc.f_cpu_hz);
  for (int i = 0; i < 8 && period != sc::kPeriodSilent && period < sc::kPeriodQ8Min; ++i)
    period = hz_to_period_q8(note_hz(pitch -= 12.0, config_.a4_hz), mc.f_cpu_hz);
  for (int i = 0; i < 8 && (period == sc::kPeriodSilent || period > sc::kPeriodQ8Max); ++i)
    period = hz_to_period_q8(note_hz(pitch += 12.0, config_.a4_hz), mc.f_cpu_hz);
  period_[m] = period;
}

void Allocator::retune_channel(uint8_t ch) noexcept {
  for (size_t m = 0; m < config_.motor_count; ++m)
    if (voices_[m].active && voices_[m].channel == ch) retune(m);
}

}  // namespace stepchoir

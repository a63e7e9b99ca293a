// allocator.cpp: the note-to-motor allocation engine (see allocator.h for the rules it follows).
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

// Forgets every note and resets every channel; derives each motor's owning channel.
void Allocator::reset_state() noexcept {
  voices_.fill(Voice{});
  glide_.fill(Glide{});
  last_pitch_.fill(0.0);
  silent_us_.fill(0);
  channels_.fill(Channel{});
  channels_[kGmDrumChannel].percussion = true;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    owner_[m] = kNone;
    if (m >= config_.motor_count) continue;
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
        else if (!channels_[ch].percussion || config_.sing_percussion) note_on(ch, e.data1);
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

uint8_t Allocator::vibrato_amount(uint8_t ch) const noexcept {
  const Channel &c = channels_[ch];
  return config_.vibrato.aftertouch && c.pressure > c.mod ? c.pressure : c.mod;
}

bool Allocator::vibrating() const noexcept {
  for (size_t m = 0; m < config_.motor_count; ++m)
    if (voices_[m].active && (vibrato_amount(voices_[m].channel) > 0 || glide_[m].duration_us > 0)) return true;
  return false;
}

size_t Allocator::tick(uint64_t now_us, sc::PeriodEntry *out, size_t max_out) noexcept {
  if (now_us > now_us_) now_us_ = now_us;
  for (size_t m = 0; m < config_.motor_count; ++m) {
    if (!voices_[m].active) continue;
    const bool gliding = glide_[m].duration_us > 0;
    if (gliding && !glide_[m].active(now_us_)) glide_[m] = Glide{};  // landed: this retune is exact
    if (gliding || vibrato_amount(voices_[m].channel) > 0) retune(m);
  }
  return flush(out, max_out);
}

// Called from: poly_note_on and mono_update, when motor m takes a new note of channel ch. The
// motor slides from what it played if the channel glides and (always, in mono) the motor sounds
// or fell silent within kGlideAfterSilenceUs.
void Allocator::start_glide(size_t m, uint8_t ch, bool always) noexcept {
  const Channel &c = channels_[ch];
  const bool recent = always || (silent_us_[m] == 0 ? last_pitch_[m] > 0 : now_us_ - silent_us_[m] <= kGlideAfterSilenceUs);
  if (!c.glide || c.glide_time == 0 || !recent || last_pitch_[m] <= 0) {
    glide_[m] = Glide{};
    return;
  }
  glide_[m] = Glide{last_pitch_[m], now_us_, c.glide_time * kGlideUsPerStep};
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

// ---------------------------------------------------------------------------------------------
// Notes
// ---------------------------------------------------------------------------------------------

void Allocator::note_on(uint8_t ch, uint8_t note) noexcept {
  if (is_poly()) {
    poly_note_on(ch, note);
  } else {
    mono_push(ch, note);
    mono_update(ch);
  }
}

void Allocator::note_off(uint8_t ch, uint8_t note) noexcept {
  Channel &c = channels_[ch];
  if (!is_poly()) {
    bool found = false;
    for (uint8_t i = 0; i < c.depth; ++i) found |= c.keys[i] == note;
    if (!found || c.key_up[note]) return;
    if (c.pedal) c.key_up[note] = true;
    else mono_remove(ch, note);
    mono_update(ch);
    return;
  }
  // Only the motor playing this key of this channel, and only while the key is down.
  for (size_t m = 0; m < config_.motor_count; ++m) {
    Voice &v = voices_[m];
    if (!v.active || !v.held || v.channel != ch || v.note != note) continue;
    if (c.pedal) {
      v.held = false;
      v.sustained = true;
    } else {
      release(m);
    }
    return;  // at most one motor plays a given key of a channel
  }
}

void Allocator::poly_note_on(uint8_t ch, uint8_t note) noexcept {
  const size_t n = config_.motor_count;
  // Struck again while it still sounds (held, or held by the pedal): the same motor carries
  // on, so repeating a key never takes a second motor.
  for (size_t m = 0; m < n; ++m) {
    Voice &v = voices_[m];
    if (v.active && v.channel == ch && v.note == note) {
      v.held = true;
      v.sustained = false;
      v.started = ++sequence_;
      return;
    }
  }
  // A free motor that can play it, fewest octaves of folding first, then lowest index; a
  // gliding channel first takes the motor that fell silent last, within kGlideAfterSilenceUs.
  size_t best = kNone;
  int best_octaves = 0;
  uint8_t best_played = 0;
  uint64_t best_silent = 0;
  for (size_t m = 0; m < n; ++m) {
    uint8_t played;
    int octaves;
    if (voices_[m].active || !resolve(m, note, &played, &octaves)) continue;
    const uint64_t silent = channels_[ch].glide && silent_us_[m] && now_us_ - silent_us_[m] <= kGlideAfterSilenceUs
                                ? silent_us_[m]
                                : 0;
    if (best == kNone || silent > best_silent || (silent == best_silent && octaves < best_octaves)) {
      best = m;
      best_octaves = octaves;
      best_played = played;
      best_silent = silent;
    }
  }
  if (best == kNone) {
    best = poly_victim(note);
    if (best == kNone) return;  // every motor is busy with a note the priority keeps
    int octaves;
    resolve(best, note, &best_played, &octaves);
  }
  voices_[best] = Voice{true, ch, note, best_played, true, false, ++sequence_, now_us_};
  start_glide(best, ch, false);
  retune(best);
}

size_t Allocator::poly_victim(uint8_t note) const noexcept {
  size_t victim = kNone;
  for (size_t m = 0; m < config_.motor_count; ++m) {
    const Voice &v = voices_[m];
    uint8_t played;
    int octaves;
    if (!v.active || !resolve(m, note, &played, &octaves)) continue;
    if (victim == kNone) {
      victim = m;
      continue;
    }
    const Voice &w = voices_[victim];
    switch (config_.priority) {
      case Priority::kOldest: if (v.started < w.started) victim = m; break;
      case Priority::kLowest:
        if (v.note > w.note || (v.note == w.note && v.started < w.started)) victim = m;
        break;
      case Priority::kHighest:
        if (v.note < w.note || (v.note == w.note && v.started < w.started)) victim = m;
        break;
    }
  }
  if (victim == kNone) return kNone;
  // The priority keeps the sounding notes when the new one ranks below all of them.
  const uint8_t kept = voices_[victim].note;
  if (config_.priority == Priority::kLowest && note > kept) return kNone;
  if (config_.priority == Priority::kHighest && note < kept) return kNone;
  return victim;
}

void Allocator::mono_push(uint8_t ch, uint8_t note) noexcept {
  Channel &c = channels_[ch];
  mono_remove(ch, note);  // a repeated key moves to the top instead of appearing twice
  c.keys[c.depth++] = note;
}

void Allocator::mono_remove(uint8_t ch, uint8_t note) noexcept {
  Channel &c = channels_[ch];
  uint8_t j = 0;
  for (uint8_t i = 0; i < c.depth; ++i)
    if (c.keys[i] != note) c.keys[j++] = c.keys[i];
  c.depth = j;
  c.key_up[note] = false;
}

void Allocator::mono_update(uint8_t ch) noexcept {
  const Channel &c = channels_[ch];
  for (size_t m = 0; m < config_.motor_count; ++m) {
    if (owner_[m] != ch) continue;
    uint8_t played;
    int octaves;
    if (c.depth == 0 || !resolve(m, c.keys[c.depth - 1], &played, &octaves)) {
      release(m);
      continue;
    }
    const uint8_t note = c.keys[c.depth - 1];
    Voice &v = voices_[m];
    if (!v.active || v.note != note) {
      v.started = ++sequence_;
      start_glide(m, ch, true);  // mono: legato or not, from the note the motor played before
    }
    if (!v.active) v.onset_us = now_us_;  // a legato change keeps the vibrato's phase
    v.active = true;
    v.channel = ch;
    v.note = note;
    v.played = played;
    v.held = !c.key_up[note];
    v.sustained = c.key_up[note];
    retune(m);
  }
}

bool Allocator::resolve(size_t m, uint8_t note, uint8_t *played, int *octaves) const noexcept {
  return resolve_note(config_.motors[m], note, played, octaves);
}

bool resolve_note(const MotorConfig &mc, uint8_t note, uint8_t *played, int *octaves) noexcept {
  const int lo = mc.lowest_note, hi = mc.highest_note;
  const int want = note + mc.transpose;
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
  if (!v.active) {
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

// ---------------------------------------------------------------------------------------------
// Controllers
// ---------------------------------------------------------------------------------------------

void Allocator::control_change(uint8_t ch, uint8_t cc, uint8_t value) noexcept {
  Channel &c = channels_[ch];
  switch (cc) {
    case kCcSustain: set_pedal(ch, value >= 64); break;
    case kCcModWheel:
      c.mod = value;
      retune_channel(ch);
      break;
    case kCcPortamentoTime: c.glide_time = value; break;
    case kCcPortamento: c.glide = value >= 64; break;
    case kCcBankSelectMsb: c.bank = value; break;
    case kCcRpnMsb: c.rpn_msb = value; break;
    case kCcRpnLsb: c.rpn_lsb = value; break;
    case kCcNrpnMsb:
    case kCcNrpnLsb:  // data entry now belongs to an NRPN, which nothing here honours
      c.rpn_msb = c.rpn_lsb = 127;
      break;
    case kCcDataEntryMsb:
    case kCcDataEntryLsb:
      if (c.rpn_msb != 0 || c.rpn_lsb != 0) break;  // only RPN 0, pitch-bend sensitivity
      if (cc == kCcDataEntryMsb) c.range_semitones = value;
      else c.range_cents = value;
      retune_channel(ch);
      break;
    case kCcAllSoundOff: all_sound_off(ch); break;
    case kCcResetAllControllers:
      set_pedal(ch, false);
      c.bend = kBendCentre;
      c.range_semitones = kDefaultBendRange;
      c.range_cents = 0;
      c.rpn_msb = c.rpn_lsb = 127;
      c.mod = c.pressure = 0;
      c.glide = false;
      retune_channel(ch);
      break;
    case kCcAllNotesOff:
    case 124: case 125: case 126: case 127:  // omni off/on, mono on, poly on: all notes off too
      all_notes_off(ch);
      break;
    default: break;
  }
}

void Allocator::set_pedal(uint8_t ch, bool down) noexcept {
  Channel &c = channels_[ch];
  const bool was_down = c.pedal;
  c.pedal = down;
  if (down || !was_down) return;
  // Pedal up: the notes it held end now.
  if (is_poly()) {
    for (size_t m = 0; m < config_.motor_count; ++m)
      if (voices_[m].active && voices_[m].channel == ch && voices_[m].sustained) release(m);
    return;
  }
  for (uint8_t note = 0; note < 128; ++note)
    if (c.key_up[note]) mono_remove(ch, note);
  mono_update(ch);
}

void Allocator::all_notes_off(uint8_t ch) noexcept {
  Channel &c = channels_[ch];
  if (is_poly()) {
    for (size_t m = 0; m < config_.motor_count; ++m) {
      Voice &v = voices_[m];
      if (!v.active || v.channel != ch || !v.held) continue;
      if (c.pedal) {
        v.held = false;
        v.sustained = true;
      } else {
        release(m);
      }
    }
    return;
  }
  if (c.pedal) {
    for (uint8_t i = 0; i < c.depth; ++i) c.key_up[c.keys[i]] = true;
  } else {
    c.depth = 0;
    c.key_up.reset();
  }
  mono_update(ch);
}

void Allocator::all_sound_off(uint8_t ch) noexcept {
  Channel &c = channels_[ch];
  c.depth = 0;
  c.key_up.reset();
  for (size_t m = 0; m < config_.motor_count; ++m)
    if (voices_[m].active && voices_[m].channel == ch) release(m);
}

}  // namespace stepchoir

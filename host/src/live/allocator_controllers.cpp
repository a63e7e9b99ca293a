// allocator_controllers.cpp: controllers, pedals and channel mode messages, and the vibrato and
// glide that tick() moves on between events (see allocator.h for the rules).
#include "live/allocator.h"

namespace stepchoir {

void Allocator::control_change(uint8_t ch, uint8_t cc, uint8_t value) noexcept {
  Channel &c = channels_[ch];
  switch (cc) {
    case kCcSustain: set_pedal(ch, value >= 64); break;
    case kCcModWheel:
      c.mod = value;
      retune_channel(ch);
      break;
    case kCcPortamentoTime: c.glide_us = static_cast<uint32_t>(value * kGlideUsPerStep); break;
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
      c.range_semitones = config_.bend_range;
      c.range_cents = 0;
      c.rpn_msb = c.rpn_lsb = 127;
      c.mod = c.pressure = 0;
      c.glide = config_.glide.on;
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
  if (!c.glide || c.glide_us == 0 || !recent || last_pitch_[m] <= 0) {
    glide_[m] = Glide{};
    return;
  }
  glide_[m] = Glide{last_pitch_[m], now_us_, c.glide_us};
}

}  // namespace stepchoir

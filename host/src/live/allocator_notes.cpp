// allocator_notes.cpp: where a note goes: kPoly's free motor or stolen one, and kMono/kChannel's
// note memory that points a group at its channel's newest key (see allocator.h for the rules).
#include "live/allocator.h"

namespace stepchoir {

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

}  // namespace stepchoir

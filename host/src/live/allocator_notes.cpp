// allocator_notes.cpp: where a note goes: kPoly's zones (each a voice of the note), a free motor, a doubler's or a stolen one, and a
// loud note's extra motors in unison; kMono/kChannel's note memory that points a group at its
// channel's newest key (see allocator.h for the rules).
#include "live/allocator.h"

namespace stepchoir {

void Allocator::note_on(uint8_t ch, uint8_t note, uint8_t velocity) noexcept {
  if (is_poly()) {
    poly_note_on(ch, note, config_.velocity.extra_motors(velocity));
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
  // The motors playing this key of this channel (its own and its doublers), while the key is down.
  for (size_t m = 0; m < config_.motor_count; ++m) {
    Voice &v = voices_[m];
    if (!v.active || !v.held || v.channel != ch || v.note != note) continue;
    if (c.pedal) {
      v.held = false;
      v.sustained = true;
    } else {
      release(m);
    }
  }
}

void Allocator::poly_note_on(uint8_t ch, uint8_t note, uint8_t extra) noexcept {
  const uint32_t unmuted = ~muted_mask();
  if (config_.zone_count == 0) {
    poly_place(ch, note, extra, kNone, unmuted);
    return;
  }
  for (size_t z = 0; z < config_.zone_count; ++z)  // a voice in every zone that covers the key: layers
    if (config_.zones[z].covers(ch, note)) poly_place(ch, note, extra, static_cast<uint8_t>(z), config_.zones[z].motors & unmuted);
}

void Allocator::poly_place(uint8_t ch, uint8_t note, uint8_t extra, uint8_t layer, uint32_t allowed) noexcept {
  const size_t n = config_.motor_count;
  // Struck again while it still sounds (held, or held by the pedal): the same motor carries
  // on, so repeating a key never takes a second motor for its own; its doublers follow the
  // new velocity.
  for (size_t m = 0; m < n; ++m) {
    const Voice &own = voices_[m];
    if (!own.active || own.doubler || own.channel != ch || own.note != note || own.layer != layer) continue;
    ++sequence_;
    for (size_t d = 0; d < n; ++d) {
      Voice &v = voices_[d];
      if (!same_key(d, m)) continue;
      v.held = true;
      v.sustained = false;
      v.started = sequence_;
    }
    set_doublers(m, extra, allowed);
    return;
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
    if (!(allowed >> m & 1) || voices_[m].active || !resolve(m, note, &played, &octaves)) continue;
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
    best = spare_motor(note, allowed);  // a motor in unison with another: no note stops
    if (best == kNone) best = poly_victim(note, allowed);
    if (best == kNone) return;  // every motor is busy with a note the priority keeps
    hand_over(best);
    int octaves;
    resolve(best, note, &best_played, &octaves);
  }
  voices_[best] = Voice{true, ch, note, best_played, true, false, ++sequence_, now_us_, false, layer};
  start_glide(best, ch, false);
  retune(best);
  set_doublers(best, extra, allowed);
}

size_t Allocator::poly_victim(uint8_t note, uint32_t allowed) const noexcept {
  size_t victim = kNone;
  for (size_t m = 0; m < config_.motor_count; ++m) {
    const Voice &v = voices_[m];
    uint8_t played;
    int octaves;
    if (!(allowed >> m & 1) || !v.active || !resolve(m, note, &played, &octaves)) continue;
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

// ---------------------------------------------------------------------------------------------
// kPoly velocity doubling (live/velocity.h): a loud note's extra motors in unison
// ---------------------------------------------------------------------------------------------

bool Allocator::same_key(size_t m, size_t p) const noexcept {
  const Voice &v = voices_[m], &w = voices_[p];
  return v.active && w.active && v.channel == w.channel && v.note == w.note && v.layer == w.layer;
}

size_t Allocator::key_motors(size_t p) const noexcept {
  size_t count = 0;
  for (size_t m = 0; m < config_.motor_count; ++m) count += same_key(m, p);
  return count;
}

void Allocator::set_doublers(size_t p, uint8_t want, uint32_t allowed) noexcept {
  const size_t n = config_.motor_count;
  size_t have = key_motors(p) - 1;
  // Too many (a softer strike of a sounding key): the highest motors go first.
  for (size_t m = n; m-- > 0 && have > want;) {
    if (m == p || !same_key(m, p)) continue;
    release(m);
    --have;
  }
  // Too few: free motors that play the note's very pitch (its played note, after their own
  // transpose, folding and mutes), the fewest octaves of folding first, then the lowest index.
  for (; have < want; ++have) {
    size_t best = kNone;
    int best_octaves = 0;
    for (size_t m = 0; m < n; ++m) {
      uint8_t played;
      int octaves;
      if (!(allowed >> m & 1) || voices_[m].active || !resolve(m, voices_[p].note, &played, &octaves) ||
          played != voices_[p].played)
        continue;
      if (best == kNone || octaves < best_octaves) best = m, best_octaves = octaves;
    }
    if (best == kNone) return;
    voices_[best] = voices_[p];
    voices_[best].doubler = true;
    glide_[best] = glide_[p];  // the same slide, so the unison holds while it glides
    retune(best);
  }
}

size_t Allocator::spare_motor(uint8_t note, uint32_t allowed) const noexcept {
  size_t spare = kNone, spare_key = 0;
  for (size_t m = 0; m < config_.motor_count; ++m) {
    uint8_t played;
    int octaves;
    const size_t key = voices_[m].active ? key_motors(m) : 0;
    if (!(allowed >> m & 1) || key < 2 || !resolve(m, note, &played, &octaves)) continue;
    const Voice &v = voices_[m];
    const Voice *w = spare == kNone ? nullptr : &voices_[spare];
    // The biggest unison first, then a doubler rather than the note's own motor, then the oldest note.
    if (!w || key > spare_key || (key == spare_key && (v.doubler > w->doubler ||
                                                       (v.doubler == w->doubler && v.started < w->started)))) {
      spare = m;
      spare_key = key;
    }
  }
  return spare;
}

void Allocator::hand_over(size_t m) noexcept {
  if (!voices_[m].active || voices_[m].doubler) return;
  for (size_t d = 0; d < config_.motor_count; ++d) {
    if (d == m || !same_key(d, m)) continue;
    voices_[d].doubler = false;  // the note's own motor now; it goes on sounding
    return;
  }
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

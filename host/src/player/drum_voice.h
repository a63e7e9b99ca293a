// drum_voice.h: a General MIDI drum hit as a short burst one motor can play: the kick low and
// long, the snare in the middle, toms graded between, hats and cymbals high and short (pure).
#ifndef STEPCHOIR_HOST_PLAYER_DRUM_VOICE_H
#define STEPCHOIR_HOST_PLAYER_DRUM_VOICE_H

#include <cstdint>

namespace stepchoir {

struct DrumBurst {
  uint8_t note = 0;      // MIDI note the motor plays (before its range and folding)
  double length_s = 0;   // how long it sounds, at most (a following hit cuts it)
  uint8_t rank = 0;      // of hits at one time, the lowest rank plays: kick 0, snare 1, toms 2,
                         // cymbals 3, hats 4, the rest 5
};

// The burst for GM percussion key gm_key (35-81 in General MIDI; other keys sound as the rest).
// Called from: plan_song.
DrumBurst drum_burst(uint8_t gm_key);

// Hits closer than this on the drum motor: the later one is left out (a flam or a kick and hat
// together sound as the one that matters most).
constexpr double kDrumHitGapS = 0.02;

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_DRUM_VOICE_H

// drum_voice.cpp: the General MIDI percussion map (keys 35-81) as motor bursts.
#include "player/drum_voice.h"

namespace stepchoir {

DrumBurst drum_burst(uint8_t k) {
  switch (k) {
    case 35: return {26, 0.09, 0};  // acoustic bass drum
    case 36: return {28, 0.08, 0};  // bass drum 1
    // The snares sit a fifth and more above the highest tom, so that a listener tells them apart
    // (tests/e2e/test_drums.cpp; bench/results/drums.md).
    case 37: return {62, 0.03, 1};  // side stick
    case 38: return {57, 0.06, 1};  // acoustic snare
    case 39: return {60, 0.05, 1};  // hand clap
    case 40: return {59, 0.06, 1};  // electric snare
    case 41: return {38, 0.09, 2};  // low floor tom
    case 43: return {41, 0.09, 2};  // high floor tom
    case 45: return {43, 0.08, 2};  // low tom
    case 47: return {45, 0.08, 2};  // low-mid tom
    case 48: return {48, 0.07, 2};  // hi-mid tom
    case 50: return {50, 0.07, 2};  // high tom
    case 42: return {98, 0.025, 4};  // closed hi-hat
    case 44: return {96, 0.025, 4};  // pedal hi-hat
    case 46: return {97, 0.09, 4};   // open hi-hat
    case 49: case 57: return {94, 0.15, 3};  // crash
    case 52: case 55: return {99, 0.1, 3};   // china, splash
    case 51: case 59: return {91, 0.04, 3};  // ride
    case 53: return {93, 0.06, 3};           // ride bell
    default: return {86, 0.03, 5};           // tambourine, cowbell, the latin kit
  }
}

}  // namespace stepchoir

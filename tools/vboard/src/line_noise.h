// line_noise.h: faults on the host-to-board line: bytes dropped, corrupted or duplicated at
// given rates, from a seed (reproducible). Pure: no simavr, unit-tested.
#ifndef STEPCHOIR_VBOARD_LINE_NOISE_H
#define STEPCHOIR_VBOARD_LINE_NOISE_H

#include <cstdint>
#include <random>

namespace vboard {

// Per-byte fault probabilities, each 0-1.
struct LineNoiseRates {
  double drop = 0;       // the byte never arrives
  double corrupt = 0;    // one or more of its bits flip
  double duplicate = 0;  // it arrives twice in a row
  bool any() const { return drop > 0 || corrupt > 0 || duplicate > 0; }
};

// What the line does to one byte: delivers `count` copies (0, 1 or 2) of `byte`.
struct LineOutcome {
  uint8_t byte;
  uint8_t count;
};

// Applies the rates byte by byte and counts what it did.
class LineNoise {
 public:
  LineNoise(const LineNoiseRates &rates, uint64_t seed) : rates_(rates), rng_(seed) {}

  // Called from: the UART bridge, for every host byte. At most one fault per byte.
  LineOutcome pass(uint8_t byte) {
    if (!rates_.any()) return {byte, 1};
    const double u = unit_(rng_);
    if (u < rates_.drop) {
      ++dropped_;
      return {byte, 0};
    }
    if (u < rates_.drop + rates_.corrupt) {
      ++corrupted_;
      const uint8_t flips = static_cast<uint8_t>(1 + rng_() % 255);  // never 0: the byte changes
      return {static_cast<uint8_t>(byte ^ flips), 1};
    }
    if (u < rates_.drop + rates_.corrupt + rates_.duplicate) {
      ++duplicated_;
      return {byte, 2};
    }
    return {byte, 1};
  }

  uint64_t dropped() const { return dropped_; }
  uint64_t corrupted() const { return corrupted_; }
  uint64_t duplicated() const { return duplicated_; }

 private:
  LineNoiseRates rates_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  uint64_t dropped_ = 0, corrupted_ = 0, duplicated_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_LINE_NOISE_H

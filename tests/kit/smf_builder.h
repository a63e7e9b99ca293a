// smf_builder.h: builds Standard MIDI File bytes for tests (header, tracks, events), so each
// test states the exact bytes it feeds the reader.
#ifndef STEPCHOIR_TESTS_SMF_BUILDER_H
#define STEPCHOIR_TESTS_SMF_BUILDER_H

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace smf {

using Bytes = std::vector<uint8_t>;

// Appends a variable-length quantity. Called by the builders below.
inline void vlq(Bytes &out, uint32_t v) {
  uint8_t tmp[5];
  int n = 0;
  tmp[n++] = v & 0x7F;
  while (v >>= 7) tmp[n++] = static_cast<uint8_t>(0x80 | (v & 0x7F));
  while (n) out.push_back(tmp[--n]);
}

// Appends a big-endian 32-bit number. Called by chunk.
inline void u32(Bytes &out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<uint8_t>(v >> s));
}

// One track's events: delta time then the raw event bytes (status may be left out for running
// status). Called by the tests.
struct Track {
  Bytes bytes;
  // Adds an event after delta ticks.
  Track &ev(uint32_t delta, std::initializer_list<uint8_t> b) {
    vlq(bytes, delta);
    bytes.insert(bytes.end(), b);
    return *this;
  }
  // Adds a Set Tempo meta event.
  Track &tempo(uint32_t delta, uint32_t us_per_qn) {
    return ev(delta, {0xFF, 0x51, 0x03, static_cast<uint8_t>(us_per_qn >> 16), static_cast<uint8_t>(us_per_qn >> 8),
                      static_cast<uint8_t>(us_per_qn)});
  }
  // Adds End of Track.
  Track &end(uint32_t delta = 0) { return ev(delta, {0xFF, 0x2F, 0x00}); }
};

// Appends a chunk with its real length. Called by file.
inline void chunk(Bytes &out, const char *type, const Bytes &body) {
  out.insert(out.end(), type, type + 4);
  u32(out, static_cast<uint32_t>(body.size()));
  out.insert(out.end(), body.begin(), body.end());
}

// A whole file: MThd then one MTrk per track.
inline Bytes file(uint16_t format, uint16_t division, const std::vector<Track> &tracks) {
  Bytes out;
  const auto n = static_cast<uint16_t>(tracks.size());
  chunk(out, "MThd",
        {static_cast<uint8_t>(format >> 8), static_cast<uint8_t>(format), static_cast<uint8_t>(n >> 8),
         static_cast<uint8_t>(n), static_cast<uint8_t>(division >> 8), static_cast<uint8_t>(division)});
  for (const auto &t : tracks) chunk(out, "MTrk", t.bytes);
  return out;
}

}  // namespace smf

#endif  // STEPCHOIR_TESTS_SMF_BUILDER_H

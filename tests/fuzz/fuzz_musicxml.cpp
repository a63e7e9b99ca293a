// fuzz_musicxml.cpp: libFuzzer target for the MusicXML reader (text and .mxl), and the G-code
// planner on what it reads.
#include <cstddef>
#include <cstdint>

#include "fuzz_plan.h"
#include "song/song.h"

// Called by libFuzzer with each input.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  try {
    fuzz_plan(stepchoir::read_musicxml(data, size, "fuzz.musicxml"));
  } catch (const stepchoir::SongError &) {
  }
  return 0;
}

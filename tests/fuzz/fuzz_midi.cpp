// fuzz_midi.cpp: libFuzzer target for the Standard MIDI File reader, and the G-code planner on
// what it reads.
#include <cstddef>
#include <cstdint>

#include "fuzz_plan.h"
#include "song/song.h"

// Called by libFuzzer with each input.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  try {
    fuzz_plan(stepchoir::read_midi(data, size, "fuzz.mid"));
  } catch (const stepchoir::SongError &) {
  }
  return 0;
}

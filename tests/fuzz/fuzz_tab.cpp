// fuzz_tab.cpp: libFuzzer target for the guitar tab (.tab) reader, and the G-code planner on what it reads.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_plan.h"
#include "song/song.h"

// Called by libFuzzer with each input.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  try {
    const stepchoir::Song song =
        stepchoir::read_tab(std::string_view(reinterpret_cast<const char *>(data), size), "fuzz.tab");
    fuzz_plan(song);
  } catch (const stepchoir::SongError &) {
  }
  return 0;
}

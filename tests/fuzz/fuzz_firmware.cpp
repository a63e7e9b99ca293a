// fuzz_firmware.cpp: libFuzzer target for the firmware's frame decoder and command handlers
// (host build, on the recording hal): any byte stream, with the clock moving and the main
// loop's poll() between bytes, must neither crash nor trip a sanitizer.
#include <cstddef>
#include <cstdint>

#include "commands.h"
#include "fake_hal.h"

// Called by libFuzzer with each input. Every 16th byte also advances the board clock by an
// amount taken from the input (so the watchdog and the timestamped queue run too).
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static cmd::Commands c;
  g_hal.reset();
  c = cmd::Commands();
  c.init();
  for (size_t i = 0; i < size; ++i) {
    c.on_byte(data[i]);
    if (i % 16 == 15) {
      g_hal.now += static_cast<uint32_t>(data[i]) << 12;
      c.poll();
    }
    if (g_hal.calls.size() > 4096) g_hal.calls.clear();  // bounded memory on long inputs
    if (g_hal.sent.size() > 65536) g_hal.sent.clear();
    if (g_hal.replies.size() > 4096) g_hal.replies.clear();
  }
  c.poll();
  return 0;
}

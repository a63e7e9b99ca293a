// fuzz_config.cpp: libFuzzer target for the live configuration loader (TOML): any text either
// loads or is refused with an error naming where; nothing else may escape, nothing may crash.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "config/config.h"

// Called by libFuzzer with each input.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  try {
    stepchoir::parse_config(std::string(reinterpret_cast<const char *>(data), size), "fuzz.toml");
  } catch (const std::runtime_error &) {
  } catch (const std::invalid_argument &) {
  }
  return 0;
}

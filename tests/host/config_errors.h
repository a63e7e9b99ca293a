// config_errors.h: the rig file's mistakes as the config tests read them
// (test_config.cpp, test_config_presets.cpp).
#ifndef STEPCHOIR_TESTS_HOST_CONFIG_ERRORS_H
#define STEPCHOIR_TESTS_HOST_CONFIG_ERRORS_H

#include <stdexcept>
#include <string>

#include "config/config.h"

// The message of the error parse_config throws for text read as "f.toml" ("" when it does not throw).
inline std::string error_of(const std::string &text) {
  try {
    stepchoir::parse_config(text, "f.toml");
  } catch (const std::runtime_error &e) {
    return e.what();
  }
  return "";
}

#endif  // STEPCHOIR_TESTS_HOST_CONFIG_ERRORS_H

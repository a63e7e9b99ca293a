// options.h: command-line options of stepchoir-vboard.
#ifndef STEPCHOIR_VBOARD_OPTIONS_H
#define STEPCHOIR_VBOARD_OPTIONS_H

#include <cstdint>
#include <string>
#include <vector>

namespace vboard {

// Parsed command line.
struct Options {
  std::string board;       // "uno" | "mega"
  std::string elf_path;    // empty = default next to the binary
  std::string link_path;   // empty = no symlink
  std::string trace_path;  // empty = no trace
  std::string eeprom_path; // empty = an erased EEPROM every run (a new board)
  double clock_ppm = 0;
  bool pacing = true;
  double speed = 1.0;  // pacing: simulated seconds per wall second
  double seconds = 0;  // 0 = until SIGINT/SIGTERM
  int64_t travel_steps = 3200;
  int64_t start_position_steps = 0;
  bool start_position_given = false;
  bool switch_active_low = true;
  uint64_t chatter_us = 0;
  int stuck_switch_motor = -1;  // --stuck-switch M: motor M's switches stay pressed
  int dead_switch_motor = -1;   // --dead-switch M: motor M's switches never close
  struct MotorPin {
    int motor;
    int arduino;
  };
  std::vector<MotorPin> sleep_pins, reset_pins;  // --sleep-pin M=PIN, --reset-pin M=PIN
  uint64_t wake_us = 1000;  // a driver takes steps this long after its SLEEP rose
  uint64_t seed = 1;
  double line_drop = 0, line_corrupt = 0, line_duplicate = 0;  // per host byte, 0-0.5
  std::string link_model = "16u2";  // the USB bridge: ideal | 16u2 | ftdi | ch340 (an Uno or Mega R3)
  unsigned ftdi_latency_ms = 16;     // the ftdi model's latency timer, 1-255
  bool bootloader = true;  // the board's bootloader in flash, run at every reset
  bool auto_reset = true;  // the host's open of the pty resets the board (DTR)
  bool trace_frames = false;  // a trace row for every host frame's delimiter
  bool quiet = false;
  bool exit_with_parent = false;  // stop when the process that started it is gone
  bool measure = true;
  bool help = false;
};

// Parses argv; on error fills error and returns false.
bool parse_options(int argc, char **argv, Options &options, std::string &error);
// Usage text.
const char *usage_text();

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_OPTIONS_H

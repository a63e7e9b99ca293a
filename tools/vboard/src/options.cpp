// options.cpp: command-line parsing for stepchoir-vboard.
#include "options.h"

#include "usb_bridge.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace vboard {

namespace {

// Parses a whole string as a signed integer.
bool parse_int(const std::string &text, int64_t &value) {
  if (text.empty()) return false;
  char *end = nullptr;
  errno = 0;
  const long long parsed = std::strtoll(text.c_str(), &end, 10);
  if (errno != 0 || *end != '\0') return false;
  value = parsed;
  return true;
}

// Parses a whole string as a finite real number.
bool parse_real(const std::string &text, double &value) {
  if (text.empty()) return false;
  char *end = nullptr;
  errno = 0;
  const double parsed = std::strtod(text.c_str(), &end);
  if (errno != 0 || *end != '\0' || !std::isfinite(parsed)) return false;
  value = parsed;
  return true;
}

// Parses "M=PIN": a motor index 0-7 and an Arduino pin number 0-127.
bool parse_motor_pin(const std::string &text, Options::MotorPin &out) {
  const size_t eq = text.find('=');
  int64_t motor = 0, pin = 0;
  if (eq == std::string::npos || !parse_int(text.substr(0, eq), motor) || !parse_int(text.substr(eq + 1), pin))
    return false;
  if (motor < 0 || motor > 7 || pin < 0 || pin > 127) return false;
  out = {static_cast<int>(motor), static_cast<int>(pin)};
  return true;
}

}  // namespace

// Usage text.
const char *usage_text() {
  return "usage: stepchoir-vboard --board uno|mega [--elf PATH] [--link PATH] [--clock-ppm N]\n"
         "          [--no-pacing | --speed X] [--seconds S] [--trace FILE.csv] [--eeprom FILE]\n"
         "          [--travel-steps N]\n"
         "          [--start-position N] [--switch-active high|low] [--chatter-us N] [--stuck-switch M]\n"
         "          [--dead-switch M]\n"
         "          [--sleep-pin M=PIN] [--reset-pin M=PIN] [--wake-us N]\n"
         "          [--seed N] [--line-drop P] [--line-corrupt P] [--line-duplicate P]\n"
         "          [--link-model ideal|16u2|ftdi|ch340] [--ftdi-latency-ms N]\n"
         "          [--auto-reset | --no-auto-reset] [--no-bootloader]\n"
         "          [--trace-frames] [--no-measure] [--exit-with-parent] [--quiet]\n"
         "Runs the stepchoir firmware ELF in simavr; UART0 is a pty (printed as 'pty: PATH').\n"
         "  --elf PATH          firmware (default <bindir>/../firmware/stepchoir-<board>.elf)\n"
         "  --link PATH         symlink to the pty, removed on exit\n"
         "  --clock-ppm N       crystal error: the board runs 16e6*(1+N/1e6) cycles per second\n"
         "  --no-pacing         run as fast as possible instead of in real time\n"
         "  --speed X           run X times as fast as real time (as far as the machine can)\n"
         "  --seconds S         stop after S simulated seconds (default: until SIGINT/SIGTERM)\n"
         "  --trace FILE        CSV of step/dir/enable/endstop/bounce events\n"
         "  --eeprom FILE       the board's EEPROM: read from FILE at start if it exists, written\n"
         "                      back at exit (the same board again; default: erased every run)\n"
         "  --travel-steps N    rail length (default 3200); --start-position N (default N/2)\n"
         "  --switch-active L   level of a pressed end switch (default low)\n"
         "  --chatter-us N      contact bounce after each switch change, spread over N us\n"
         "  --stuck-switch M    the switches of motor M read pressed all the time (a fault)\n"
         "  --dead-switch M     the switches of motor M never read pressed (a broken wire)\n"
         "  --sleep-pin M=PIN   motor M's driver SLEEP input is wired to Arduino pin PIN (repeatable)\n"
         "  --reset-pin M=PIN   motor M's driver RESET input is wired to Arduino pin PIN (repeatable)\n"
         "  --wake-us N         a driver takes steps N us after its SLEEP rose (default 1000); a step\n"
         "                      while asleep, waking, disabled or in reset is lost (summary lost_steps)\n"
         "  --seed N            seed for the bounce pattern and line noise (default 1)\n"
         "  --line-drop P       line noise: each host byte is lost with probability P (0-0.5)\n"
         "  --line-corrupt P    ... has one or more bits flipped with probability P\n"
         "  --line-duplicate P  ... arrives twice with probability P\n"
         "  --link-model M      the USB bridge between the pty and the UART (default 16u2):\n"
         "                      16u2 (Uno/Mega R3), ftdi (FT232R), ch340 (clones), ideal (bytes\n"
         "                      pass at once); docs/usb-bridges.md\n"
         "  --ftdi-latency-ms N the ftdi model's latency timer (default 16; 1-255)\n"
         "  --no-auto-reset     the host's open of the pty does not reset the board (default:\n"
         "                      it does, as DTR does on an Uno or Mega; --auto-reset says so)\n"
         "  --no-bootloader     no bootloader in flash: every reset starts the firmware at once\n"
         "  --trace-frames      also trace when each host frame's first and last byte reach the UART\n"
         "  --no-measure        skip per-instruction interrupt/ISR accounting (faster)\n"
         "  --exit-with-parent  stop (as on SIGTERM) once the process that started it is gone\n"
         "  --quiet             no summary on stderr\n"
         "SIGUSR1 presses its reset button: the MCU restarts through its bootloader, the link stays up.\n";
}

// Parses argv.
bool parse_options(int argc, char **argv, Options &options, std::string &error) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    // Returns the option's value (the next argument), or fails.
    auto value_of = [&](std::string &value) {
      if (i + 1 >= argc) {
        error = arg + " needs a value";
        return false;
      }
      value = argv[++i];
      return true;
    };
    std::string value;
    if (arg == "-h" || arg == "--help") {
      options.help = true;
    } else if (arg == "--board") {
      if (!value_of(options.board)) return false;
      if (options.board != "uno" && options.board != "mega") {
        error = "--board must be uno or mega";
        return false;
      }
    } else if (arg == "--elf") {
      if (!value_of(options.elf_path)) return false;
    } else if (arg == "--link") {
      if (!value_of(options.link_path)) return false;
    } else if (arg == "--trace") {
      if (!value_of(options.trace_path)) return false;
    } else if (arg == "--eeprom") {
      if (!value_of(options.eeprom_path)) return false;
    } else if (arg == "--clock-ppm") {
      if (!value_of(value)) return false;
      if (!parse_real(value, options.clock_ppm) || std::fabs(options.clock_ppm) >= 1e6) {
        error = "--clock-ppm needs a number between -1e6 and 1e6";
        return false;
      }
    } else if (arg == "--link-model") {
      if (!value_of(options.link_model)) return false;
      LinkModel model;
      if (!parse_link_model(options.link_model, model)) {
        error = "--link-model must be ideal, 16u2, ftdi or ch340";
        return false;
      }
    } else if (arg == "--ftdi-latency-ms") {
      if (!value_of(value)) return false;
      int64_t ms = 0;
      if (!parse_int(value, ms) || ms < 1 || ms > 255) {
        error = "--ftdi-latency-ms needs an integer from 1 to 255";
        return false;
      }
      options.ftdi_latency_ms = static_cast<unsigned>(ms);
    } else if (arg == "--auto-reset") {
      options.auto_reset = true;
    } else if (arg == "--no-auto-reset") {
      options.auto_reset = false;
    } else if (arg == "--no-bootloader") {
      options.bootloader = false;
    } else if (arg == "--no-pacing") {
      options.pacing = false;
    } else if (arg == "--speed") {
      if (!value_of(value)) return false;
      if (!parse_real(value, options.speed) || !(options.speed >= 0.01 && options.speed <= 1000)) {
        error = "--speed needs a number between 0.01 and 1000";
        return false;
      }
    } else if (arg == "--seconds") {
      if (!value_of(value)) return false;
      if (!parse_real(value, options.seconds) || options.seconds <= 0) {
        error = "--seconds needs a positive number";
        return false;
      }
    } else if (arg == "--travel-steps") {
      if (!value_of(value)) return false;
      if (!parse_int(value, options.travel_steps) || options.travel_steps <= 0) {
        error = "--travel-steps needs a positive integer";
        return false;
      }
    } else if (arg == "--start-position") {
      if (!value_of(value)) return false;
      if (!parse_int(value, options.start_position_steps)) {
        error = "--start-position needs an integer";
        return false;
      }
      options.start_position_given = true;
    } else if (arg == "--switch-active") {
      if (!value_of(value)) return false;
      if (value != "high" && value != "low") {
        error = "--switch-active must be high or low";
        return false;
      }
      options.switch_active_low = value == "low";
    } else if (arg == "--stuck-switch" || arg == "--dead-switch") {
      int64_t motor = 0;
      if (!value_of(value)) return false;
      if (!parse_int(value, motor) || motor < 0 || motor > 7) {
        error = arg + " needs a motor index 0-7";
        return false;
      }
      (arg == "--stuck-switch" ? options.stuck_switch_motor : options.dead_switch_motor) = static_cast<int>(motor);
    } else if (arg == "--sleep-pin" || arg == "--reset-pin") {
      Options::MotorPin mp{};
      if (!value_of(value)) return false;
      if (!parse_motor_pin(value, mp)) {
        error = arg + " needs MOTOR=PIN: a motor index 0-7 and an Arduino pin number";
        return false;
      }
      (arg == "--sleep-pin" ? options.sleep_pins : options.reset_pins).push_back(mp);
    } else if (arg == "--wake-us") {
      int64_t wake_us = 0;
      if (!value_of(value)) return false;
      if (!parse_int(value, wake_us) || wake_us < 0 || wake_us > 1000000) {
        error = "--wake-us needs a whole number of microseconds, 0 to 1000000";
        return false;
      }
      options.wake_us = static_cast<uint64_t>(wake_us);
    } else if (arg == "--chatter-us") {
      int64_t chatter_us = 0;
      if (!value_of(value)) return false;
      if (!parse_int(value, chatter_us) || chatter_us < 0) {
        error = "--chatter-us needs a non-negative integer";
        return false;
      }
      options.chatter_us = static_cast<uint64_t>(chatter_us);
    } else if (arg == "--seed") {
      int64_t seed = 0;
      if (!value_of(value)) return false;
      if (!parse_int(value, seed)) {
        error = "--seed needs an integer";
        return false;
      }
      options.seed = static_cast<uint64_t>(seed);
    } else if (arg == "--line-drop" || arg == "--line-corrupt" || arg == "--line-duplicate") {
      double rate = 0;
      if (!value_of(value)) return false;
      if (!parse_real(value, rate) || rate < 0 || rate > 0.5) {
        error = arg + " needs a probability per byte between 0 and 0.5";
        return false;
      }
      (arg == "--line-drop" ? options.line_drop : arg == "--line-corrupt" ? options.line_corrupt
                                                                         : options.line_duplicate) = rate;
    } else if (arg == "--trace-frames") {
      options.trace_frames = true;
    } else if (arg == "--quiet") {
      options.quiet = true;
    } else if (arg == "--exit-with-parent") {
      options.exit_with_parent = true;
    } else if (arg == "--no-measure") {
      options.measure = false;
    } else {
      error = "unknown argument " + arg;
      return false;
    }
  }
  if (options.help) return true;
  if (options.board.empty()) {
    error = "--board uno|mega is required";
    return false;
  }
  if (!options.start_position_given) options.start_position_steps = options.travel_steps / 2;
  return true;
}

}  // namespace vboard

// board_config.h: the virtual board's view of a board table (firmware/stepchoir/boards/*.h).
#ifndef STEPCHOIR_VBOARD_BOARD_CONFIG_H
#define STEPCHOIR_VBOARD_BOARD_CONFIG_H

#include <cstdint>
#include <string>
#include <vector>

namespace vboard {

// A pin as port letter + bit; wired == false for kNoPin.
struct PinRef {
  bool wired = false;
  int arduino = -1;
  char port = '-';
  uint8_t bit = 0;
  // True when both refer to the same wired port bit.
  bool same_as(const PinRef &other) const {
    return wired && other.wired && port == other.port && bit == other.bit;
  }
};

// The pins of one driver socket the virtual board models (SLEEP and RESET: the board table's,
// or an Arduino pin --sleep-pin / --reset-pin names).
struct MotorConfig {
  char axis;
  PinRef step, dir, enable, min_switch, max_switch, sleep, reset;
};

// One board: MCU, clock and driver sockets.
struct BoardConfig {
  std::string cli_name;    // "uno" / "mega"
  std::string table_name;  // board table kName
  std::string mcu;         // simavr core name
  uint32_t f_cpu_hz = 16000000;
  unsigned vector_count = 0;  // interrupt vectors incl. reset
  unsigned eeprom_bytes = 0;  // the MCU's EEPROM (datasheet: E2END + 1)
  bool enable_active_low = true;
  std::vector<MotorConfig> motors;
  std::vector<PinRef> arduino_pins;  // Arduino pin number -> port and bit (the table's kPinMap)
  // The board's bootloader: how long it holds the board after the host's reset before the
  // firmware starts (ms), and whether it holds it at power-on too.
  double bootloader_ms = 0;
  bool bootloader_at_power_on = false;
  // A host byte that reaches the bootloader meanwhile keeps it until this much silence (ms)
  // after the latest byte; 0: bytes do not hold it.
  double bootloader_quiet_ms = 0;
};

// Fills config for "uno" or "mega"; returns false for an unknown name.
bool board_config_for(const std::string &cli_name, BoardConfig &config);

// Wires motor's driver SLEEP (sleep true) or RESET input to Arduino pin `arduino` of the board
// (--sleep-pin, --reset-pin); false with error when the board has no such motor or pin.
bool wire_driver_pin(BoardConfig &config, int motor, int arduino, bool sleep, std::string &error);

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_BOARD_CONFIG_H

// board_config.cpp: converts the firmware's constexpr board tables into BoardConfig.
#include "board_config.h"

#include "mega_ramps_14.h"
#include "uno_cnc_shield_v3.h"

namespace vboard {

namespace {

// Converts a board table pin.
PinRef to_pin_ref(const board::Pin &pin) {
  PinRef ref;
  ref.wired = pin.wired();
  ref.arduino = pin.arduino;
  ref.port = pin.port;
  ref.bit = pin.bit;
  return ref;
}

// Converts a board table's motor list.
template <size_t N>
std::vector<MotorConfig> to_motor_configs(const board::MotorPins (&motors)[N]) {
  std::vector<MotorConfig> configs;
  for (const board::MotorPins &m : motors)
    configs.push_back({m.axis, to_pin_ref(m.step), to_pin_ref(m.dir), to_pin_ref(m.enable),
                       to_pin_ref(m.min_switch), to_pin_ref(m.max_switch), to_pin_ref(m.sleep),
                       to_pin_ref(m.reset)});
  return configs;
}

// Converts a board table's Arduino pin map.
std::vector<PinRef> to_pin_refs(const uint8_t *map, uint8_t count) {
  std::vector<PinRef> pins;
  for (int n = 0; n < count; ++n) pins.push_back(to_pin_ref(board::pin_from_map(map, count, static_cast<int8_t>(n))));
  return pins;
}

}  // namespace

// Fills config for "uno" or "mega".
bool board_config_for(const std::string &cli_name, BoardConfig &config) {
  config = BoardConfig();
  config.cli_name = cli_name;
  if (cli_name == "uno") {
    namespace b = board::uno_cnc_shield_v3;
    config.table_name = b::kName;
    config.mcu = b::kMcu;
    config.vector_count = 26;  // ATmega328P
    config.eeprom_bytes = 1024;
    // Optiboot (bootloaders/optiboot/optiboot.c in Debian's arduino-core-avr; the Uno R3's): after
    // an external reset it flashes the LED 3 times (6 toggles of 62.5 ms on Timer1), then
    // waits for a programmer with a 1 s watchdog, which starts the firmware. At power-on it
    // starts the firmware at once.
    config.bootloader_ms = 6 * 62.5 + 1000;
    config.bootloader_at_power_on = false;
    config.enable_active_low = b::kEnableActiveLow;
    config.motors = to_motor_configs(b::kMotors);
    config.arduino_pins = to_pin_refs(b::kPinMap, b::kPinCount);
    return true;
  }
  if (cli_name == "mega") {
    namespace b = board::mega_ramps_14;
    config.table_name = b::kName;
    config.mcu = b::kMcu;
    config.vector_count = 57;  // ATmega2560
    config.eeprom_bytes = 4096;
    // stk500v2 (bootloaders/stk500v2/stk500boot_v2_mega2560.hex in Debian's arduino-core-avr,
    // the Mega 2560's): waits for a programmer after any reset but the watchdog's, power-on
    // included. Its hex, run on the virtual board with no byte coming, started the firmware
    // 0.833 s after the reset (docs/usb-bridges.md).
    config.bootloader_ms = 833;
    config.bootloader_at_power_on = true;
    // A byte that comes meanwhile (the host's 1 Mbaud bytes read at its 115,200 baud) takes it
    // into its message loop, which starts the firmware only after F_CPU / 2 passes of its
    // receive wait with no byte (stk500boot.c's recchar_timeout): in the Debian hex that wait is
    // a 10-cycle loop (at 0x3e700), 5.0 s; each byte starts it again. Optiboot, the Uno's,
    // ignores bytes with framing errors and is not held.
    config.bootloader_quiet_ms = 5000;
    config.enable_active_low = b::kEnableActiveLow;
    config.motors = to_motor_configs(b::kMotors);
    config.arduino_pins = to_pin_refs(b::kPinMap, b::kPinCount);
    return true;
  }
  return false;
}

// Wires a driver's SLEEP or RESET input to an Arduino pin.
bool wire_driver_pin(BoardConfig &config, int motor, int arduino, bool sleep, std::string &error) {
  const std::string what = std::string(sleep ? "--sleep-pin " : "--reset-pin ") + std::to_string(motor) + "=" +
                           std::to_string(arduino) + ": ";
  if (motor < 0 || motor >= static_cast<int>(config.motors.size())) {
    error = what + "the " + config.cli_name + " has motors 0-" + std::to_string(config.motors.size() - 1);
    return false;
  }
  if (arduino < 0 || arduino >= static_cast<int>(config.arduino_pins.size())) {
    error = what + "the " + config.cli_name + " has Arduino pins 0-" + std::to_string(config.arduino_pins.size() - 1);
    return false;
  }
  (sleep ? config.motors[motor].sleep : config.motors[motor].reset) = config.arduino_pins[arduino];
  return true;
}

}  // namespace vboard

// microstep.h: each driver's microstep-select table and default timings (pure; host-testable).
#ifndef STEPCHOIR_MICROSTEP_H
#define STEPCHOIR_MICROSTEP_H

#include <stdint.h>

#include "config.h"
#include "src/stepchoir_protocol.h"

namespace drv {

// Levels for the M0, M1, M2 pins (bit 0 = M0 ... bit 2 = M2) that select `microsteps` on
// `driver`. Returns false when the driver has no such mode, or selects it with DIP switches
// (TB6600: microsteps are set on the module, so only 0 pins are driven and any mode is taken).
//   A4988   (MS1 MS2 MS3): 1 LLL, 2 HLL, 4 LHL, 8 HHL, 16 HHH
//   DRV8825 (M0 M1 M2):    1 LLL, 2 HLL, 4 LHL, 8 HHL, 16 LLH, 32 HLH
inline bool microstep_bits(uint8_t driver, uint8_t microsteps, uint8_t *bits) {
  static const uint8_t kModes[6] = {1, 2, 4, 8, 16, 32};
  static const uint8_t kA4988[6] = {0x0, 0x1, 0x2, 0x3, 0x7, 0xFF};
  static const uint8_t kDrv8825[6] = {0x0, 0x1, 0x2, 0x3, 0x4, 0x5};
  for (uint8_t i = 0; i < 6; ++i) {
    if (kModes[i] != microsteps) continue;
    if (driver == sc::kDriverTb6600) { *bits = 0; return true; }
    const uint8_t b = driver == sc::kDriverA4988 ? kA4988[i]
                      : driver == sc::kDriverDrv8825 ? kDrv8825[i] : 0xFF;
    if (b == 0xFF) return false;
    *bits = b;
    return true;
  }
  return false;
}

// True when the driver's microstep mode is chosen with pins the firmware may drive.
inline bool microstep_by_pins(uint8_t driver) { return driver != sc::kDriverTb6600; }

// The STEP high time (us) a driver gets unless configured otherwise.
inline uint8_t default_pulse_us(uint8_t driver) {
  return driver == sc::kDriverTb6600 ? cfg::kPulseUsTb6600
         : driver == sc::kDriverDrv8825 ? cfg::kPulseUsDrv8825 : cfg::kPulseUsA4988;
}

// True when a switch input at `pin_high` (1 = the pin reads HIGH) means "pressed" for a
// switch whose active level is `active_high`: the seed's eRead table (level x reading).
inline bool switch_pressed(bool pin_high, bool active_high) { return pin_high == active_high; }

}  // namespace drv

#endif  // STEPCHOIR_MICROSTEP_H

// step_driver.h: one stepper driver socket (A4988, DRV8825, TB6600): pin setup, enable,
// sleep, reset, microstep mode through M0-M2 where wired, endstops with an active level and
// a can-go check per direction. The step timing itself lives in scheduler.h.
#ifndef STEPCHOIR_STEP_DRIVER_H
#define STEPCHOIR_STEP_DRIVER_H

#include <stdint.h>

#include "boards/pins.h"
#include "src/stepchoir_protocol.h"

class StepDriver {
 public:
  // Called from: setup(). Configures the pins of one socket; the driver starts disabled.
  void begin(const board::MotorPins &pins, bool enable_active_low);

  // Called from: main loop. Driver outputs on or off (the ENABLE pin at its active level).
  void enable(bool on);

  // Called from: main loop. Sleep mode on or off, where SLEEP is wired (1 ms wake-up).
  void sleep(bool on);

  // Called from: main loop. Pulses RESET where wired: 1 ms low, then 10 ms to settle.
  void reset();

  // Called from: main loop. Selects a microstep mode; false if the driver lacks it.
  bool set_microsteps(uint8_t driver, uint8_t microsteps);

  // Called from: anywhere. True when the switch at the end of travel in `up` direction reads
  // pressed for the configured active level.
  bool at_end(bool up) const;

  // Called from: anywhere. The seed's canGo: false when the switch ahead is pressed.
  bool can_go(bool up) const { return !at_end(up); }

  void set_active_high(bool high) { active_high_ = high; }
  bool enabled() const { return enabled_; }

 private:
  board::MotorPins pins_;
  bool enable_active_low_ = true;
  bool active_high_ = false;
  bool enabled_ = false;
};

#endif  // STEPCHOIR_STEP_DRIVER_H

namespace drivers {
// Called from: setup(). Sets up every socket of the board and the step scheduler.
void begin();
// Called from: main loop. Enables motor m's driver (and those sharing its ENABLE pin); true
// when it was disabled.
bool enable_for(uint8_t m);
// Called from: main loop. Applies a motor configuration (microstep pins, switch level, the
// motor's motion settings); sc::kErrConfig when the driver lacks the microstep mode.
uint8_t configure(const sc::ConfigBody &c);
// Called from: main loop. Every driver off (ENABLE at its inactive level).
void disable_all();
// Called from: main loop. True when any driver is enabled.
bool any_enabled();
}  // namespace drivers

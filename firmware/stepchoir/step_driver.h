// step_driver.h: one stepper driver socket (A4988, DRV8825, TB6600): pin setup, ENABLE, SLEEP,
// RESET and the microstep mode through M0-M2 where wired; and the board's set of drivers
// (drivers::): the idle power-down and the wake before a note (driver_power.h). The step
// timing itself lives in scheduler.h. Everything here runs in the main loop, never in an ISR.
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

  // Called from: main loop. SLEEP low (asleep) or high, where wired. Does not wait: the
  // caller keeps the first STEP edge the wake time after the wake (drivers::).
  void sleep(bool on);

  // Called from: main loop. Pulses RESET low for 10 us where wired (the main loop waits them).
  void reset();

  // Called from: main loop (kMsgDriver). Uses these SLEEP and RESET pins from now on (outputs,
  // high: awake, not in reset); a pin given up goes back to an input.
  void set_power_pins(board::Pin sleep_pin, board::Pin reset_pin);

  // Called from: main loop. Selects a microstep mode; false if the driver lacks it.
  bool set_microsteps(uint8_t driver, uint8_t microsteps);

  bool enabled() const { return enabled_; }
  board::Pin sleep_pin() const { return pins_.sleep; }
  board::Pin reset_pin() const { return pins_.reset; }

 private:
  board::MotorPins pins_;
  bool enable_active_low_ = true;
  bool enabled_ = false;
};

namespace drivers {
// Called from: setup(). Sets up every socket of the board and the step scheduler.
void begin();
// Called from: main loop. Applies a motor configuration (microstep pins, switch level, the
// motor's motion settings); sc::kErrConfig when the driver lacks the microstep mode.
uint8_t configure(const sc::ConfigBody &c);
// Called from: main loop (kMsgDriver; b.motor checked). SLEEP and RESET pins, idle setting and
// wake time; sc::kErrConfig when they do not fit the board (drv::check_driver).
uint8_t configure_power(const sc::DriverBody &b);
// Called from: main loop (kMsgDriverAct; motor checked). sc::DriverAction now; sc::kErrConfig
// for an unknown action, one whose pin is not wired, or a sleep, disable or reset of a motor
// with a timed note queued.
uint8_t act(uint8_t m, uint8_t action);
// Called from: main loop, before motor m plays a live note. Wakes its driver if it is powered
// down; true while it is still waking, with the time its first edge may come in *ready.
bool ready_time(uint8_t m, uint32_t *ready);
// Bit m: motor m's driver may be asleep, disabled or still waking, so a note asks ready_time;
// clear, the driver is awake and ready_time would only say so (a live note skips its 150
// cycles). Set for every motor whenever any driver powers down or wakes; cleared by ready_time.
extern uint8_t g_unsure;
inline bool maybe_unready(uint8_t m) { return g_unsure & (uint8_t)(1u << m); }
// Called from: main loop, before a timed entry of motor m at `at` is queued. Wakes its driver
// for a note, holds it awake until `at`; returns the time to play the entry at (`at`, or the
// driver's ready time when later).
uint32_t entry_time(uint8_t m, uint32_t period_q8, uint32_t at);
// Called from: main loop, every pass. Once a millisecond: powers down the drivers whose motors
// have been silent for their idle time. Budget (by instruction count): one load a pass until
// a driver message came; then about 100 cycles a pass (a clock read), and the millisecond's
// check about 100 cycles and 50 a motor, under 2 % of the CPU with five motors.
void poll();
// Called from: main loop (stop-all, watchdog). Every driver off (ENABLE at its inactive level).
void disable_all();
// Called from: main loop (kMsgSilence). The masked motors' queued notes were dropped: their
// drivers are no longer held awake for them, and idle from now on.
void release(uint8_t mask);
// Called from: main loop. True when any driver is enabled.
bool any_enabled();
}  // namespace drivers

#endif  // STEPCHOIR_STEP_DRIVER_H

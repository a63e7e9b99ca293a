// step_driver.cpp: StepDriver on the AVR, and the board's set of drivers (drivers::).
#include "step_driver.h"

#include <util/delay.h>

#include "boards/board.h"
#include "microstep.h"
#include "pin_io.h"
#include "scheduler.h"

void StepDriver::begin(const board::MotorPins &pins, bool enable_active_low) {
  pins_ = pins;
  enable_active_low_ = enable_active_low;
  pio::output(pins_.enable, enable_active_low_);  // disabled
  pio::output(pins_.reset, true);                 // not in reset
  pio::output(pins_.sleep, true);                 // awake
  pio::output(pins_.m0, false);
  pio::output(pins_.m1, false);
  pio::output(pins_.m2, false);
  enabled_ = false;
}

void StepDriver::enable(bool on) {
  pio::write(pins_.enable, on != enable_active_low_);
  enabled_ = on;
}

void StepDriver::sleep(bool on) {
  if (!pins_.sleep.wired()) return;
  pio::write(pins_.sleep, !on);
  if (!on) _delay_ms(1);  // DRV8825/A4988: 1 ms from wake-up to the first STEP
}

void StepDriver::reset() {
  if (!pins_.reset.wired()) return;
  pio::write(pins_.reset, false);
  _delay_ms(1);
  pio::write(pins_.reset, true);
  _delay_ms(10);
}

bool StepDriver::set_microsteps(uint8_t driver, uint8_t microsteps) {
  uint8_t bits;
  if (!drv::microstep_bits(driver, microsteps, &bits)) return false;
  if (!drv::microstep_by_pins(driver)) return true;
  pio::write(pins_.m0, bits & 1);
  pio::write(pins_.m1, bits & 2);
  pio::write(pins_.m2, bits & 4);
  return true;
}

bool StepDriver::at_end(bool up) const {
  const board::Pin p = up ? pins_.max_switch : pins_.min_switch;
  return p.wired() && drv::switch_pressed(pio::read(p), active_high_);
}

namespace {
StepDriver g_drivers[board::active::kMotorCount];
}  // namespace


namespace drivers {

// Called from: setup(). Pins of every socket, then the step scheduler.
void begin() {
  sched::Wiring w[board::active::kMotorCount];
  for (uint8_t m = 0; m < board::active::kMotorCount; ++m) {
    const board::MotorPins &p = board::active::kMotors[m];
    g_drivers[m].begin(p, board::active::kEnableActiveLow);
    w[m] = {p.step, p.dir, p.min_switch, p.max_switch};
  }
  sched::init(board::active::kMotorCount, w);
}

// Called from: main loop, before a motor starts. Wakes its driver (shared enables included);
// true when it was asleep.
bool enable_for(uint8_t m) {
  if (g_drivers[m].enabled()) return false;
  if (board::active::kSharedEnable) {
    for (uint8_t i = 0; i < board::active::kMotorCount; ++i) g_drivers[i].enable(true);
  } else {
    g_drivers[m].enable(true);
  }
  return true;
}

uint8_t configure(const sc::ConfigBody &c) {
  StepDriver &d = g_drivers[c.motor];
  if (!d.set_microsteps(c.driver, c.microsteps)) return sc::kErrConfig;
  d.set_active_high(c.endstop_active_high);
  sched::Motion m;
  m.travel_steps = c.travel_steps;
  m.pulse_ticks = (uint16_t)(c.pulse_us * (F_CPU / 1000000ul));
  m.switch_active_high = c.endstop_active_high;
  m.start_period_q8 = c.start_period_q8;
  m.ramp_q8 = c.accel_q8;
  sched::set_motion(c.motor, m);
  return sc::kErrNone;
}

void disable_all() {
  for (uint8_t m = 0; m < board::active::kMotorCount; ++m) g_drivers[m].enable(false);
}

bool any_enabled() {
  for (uint8_t m = 0; m < board::active::kMotorCount; ++m)
    if (g_drivers[m].enabled()) return true;
  return false;
}

}  // namespace drivers

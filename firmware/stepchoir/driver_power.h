// driver_power.h: when a stepper driver sleeps, is disabled and wakes (kMsgDriver,
// kMsgDriverAct), pure: no pins, no clock. The drivers:: layer (step_driver.cpp) keeps one Power
// per motor and drives the pins; the host tests include this header (tests/firmware/test_driver.cpp).
//
// Who calls it: the main loop only (drivers::poll once a millisecond, hal::set_period and
// hal::queue_at before a note, the kMsgDriver handlers). Nothing here runs in an ISR.
//
//   last step  silence (idle_ms)         next note: SLEEP high   wake_us    first STEP
//   |----------------------------| SLEEP low ... |-----------------------| edge
//
// Times are board ticks (CPU cycles, wrapping at 2^32) compared as signed differences: an idle
// time is at most 65,535 ms (1.05e9 ticks at 16 MHz), inside the 2^31 a difference holds.
#ifndef STEPCHOIR_DRIVER_POWER_H
#define STEPCHOIR_DRIVER_POWER_H

#include <stdint.h>

#include "boards/pins.h"
#include "src/stepchoir_protocol.h"

namespace drv {

// Power::flags.
const uint8_t kAsleep = 0x01;   // SLEEP is low
const uint8_t kWaking = 0x02;   // woken: no STEP edge before ready_at
const uint8_t kSounded = 0x04;  // the motor sounded at the last idle check
const uint8_t kHeld = 0x08;     // a timed note of the motor is queued (the last one at quiet_since)
const uint8_t kIdle = 0x10;     // silent for its idle time, nothing queued (until it plays again)

// Arduino pins 0 and 1 are the UART's: never a SLEEP or RESET pin.
const int8_t kFirstFreePin = 2;

// One driver's idle settings and power state.
struct Power {
  uint32_t quiet_since;  // ticks: silent since then (kHeld: busy until then)
  uint32_t ready_at;     // ticks: awake from then on (while kWaking)
  uint32_t idle_ticks;   // silence before the power-down
  uint16_t wake_ticks;   // the driver's wake-up time
  uint8_t idle;          // sc::DriverIdle
  uint8_t flags;
};

// Takes a kMsgDriver's idle settings (checked: check_driver); silent from `now` on.
inline void set_idle(Power &p, uint8_t idle, uint16_t idle_ms, uint16_t wake_us, uint32_t f_cpu_hz, uint32_t now) {
  p.idle = idle;
  p.idle_ticks = (uint32_t)idle_ms * (f_cpu_hz / 1000u);
  p.wake_ticks = (uint16_t)(wake_us * (uint16_t)(f_cpu_hz / 1000000u));
  p.quiet_since = now;
  p.flags &= (uint8_t)~(kIdle | kSounded);
}

// The motor is busy at `now`: its silence counts from now, or from a queued note's later time.
inline void stir(Power &p, uint32_t now) {
  if (!(p.flags & kHeld) || (int32_t)(now - p.quiet_since) > 0) p.quiet_since = now;
  p.flags &= (uint8_t)~kIdle;
}

// The driver was woken (SLEEP high, ENABLE on or RESET released) at `now`: no STEP edge before
// now + wake_ticks. The caller clears kAsleep when SLEEP went high.
inline void woke(Power &p, uint32_t now) {
  stir(p, now);
  p.ready_at = now + p.wake_ticks;
  p.flags = (uint8_t)((p.flags & ~kWaking) | (p.wake_ticks ? kWaking : 0));
}

// True while the driver is still waking at `now`, with the time it is awake in *ready.
inline bool waking(Power &p, uint32_t now, uint32_t *ready) {
  if (!(p.flags & kWaking)) return false;
  if ((int32_t)(p.ready_at - now) <= 0) {
    p.flags &= (uint8_t)~kWaking;
    return false;
  }
  *ready = p.ready_at;
  return true;
}

// A timed note of the motor, playing at board time `at` (not before its driver's ready time),
// goes into the queue: the motor counts as busy until then (entries come in time order: the
// last is the latest).
inline void hold(Power &p, uint32_t at) {
  p.quiet_since = at;
  p.flags = (uint8_t)((p.flags | kHeld) & ~kIdle);
}

// The motor's queued timed notes were dropped (kMsgSilence) at `now`: no hold, and its silence
// counts from now.
inline void release(Power &p, uint32_t now) {
  p.flags &= (uint8_t)~kHeld;
  stir(p, now);
}

// True while a queued timed note holds the driver (its time is still to come at `now`); a hold
// whose time came is dropped. Called from: idle_due, drivers::poll (for a powered-down driver).
inline bool held(Power &p, uint32_t now) {
  if (!(p.flags & kHeld)) return false;
  if ((int32_t)(now - p.quiet_since) < 0) return true;
  p.flags &= (uint8_t)~kHeld;
  return false;
}

// Called from: drivers::poll, once a millisecond, for a driver awake and enabled (`sounding`:
// the motor's scheduler bit). True when the motor has been silent for its idle time with no
// timed entry to come, and its idle setting is not none: time to power its driver down. Stays
// true (kIdle) until the motor plays again.
inline bool idle_due(Power &p, bool sounding, uint32_t now) {
  const bool note_to_come = held(p, now);
  if (sounding) {
    p.flags = (uint8_t)((p.flags | kSounded) & ~kIdle);
    return false;
  }
  if (p.flags & kSounded) {  // fell silent since the last check: the silence counts from now
    p.flags &= (uint8_t)~kSounded;
    stir(p, now);
  }
  if (note_to_come || p.idle == sc::kIdleNone) return false;
  if (!(p.flags & kIdle) && (int32_t)(now - p.quiet_since) < (int32_t)p.idle_ticks) return false;
  p.flags |= kIdle;
  return true;
}

// True when Arduino pin `pin` (0 or more) is one of a motor's board-table pins (STEP, DIR,
// ENABLE, switches, microstep selects; an unwired one is -1).
inline bool table_uses(const board::MotorPins &m, int8_t pin) {
  return m.step.arduino == pin || m.dir.arduino == pin || m.enable.arduino == pin || m.min_switch.arduino == pin ||
         m.max_switch.arduino == pin || m.m0.arduino == pin || m.m1.arduino == pin || m.m2.arduino == pin;
}

// Whether kMsgDriver body b fits a board of `motor_count` motors (`motors`: its table) and
// `pin_count` Arduino pins, where the other drivers use driver_pins[i][0] (SLEEP) and [1]
// (RESET), sc::kPinNone if none (b.motor's own entry is not looked at). b.motor is checked by
// the caller. sc::kErrNone, or sc::kErrConfig for the refusals PROTOCOL.md lists.
inline uint8_t check_driver(const sc::DriverBody &b, const board::MotorPins *motors, uint8_t motor_count,
                            uint8_t pin_count, const int8_t (*driver_pins)[2]) {
  if (b.idle > sc::kIdleDisable || b.wake_us > sc::kWakeUsMax) return sc::kErrConfig;
  if (b.idle == sc::kIdleSleep && b.sleep_pin == sc::kPinNone) return sc::kErrConfig;
  if (b.idle == sc::kIdleDisable && !motors[b.motor].enable.wired()) return sc::kErrConfig;
  if (b.sleep_pin != sc::kPinNone && b.sleep_pin == b.reset_pin) return sc::kErrConfig;
  const int8_t pins[2] = {b.sleep_pin, b.reset_pin};
  for (uint8_t k = 0; k < 2; ++k) {
    const int8_t pin = pins[k];
    if (pin == sc::kPinNone) continue;
    if (pin < kFirstFreePin || pin >= (int)pin_count) return sc::kErrConfig;
    for (uint8_t i = 0; i < motor_count; ++i) {
      if (table_uses(motors[i], pin)) return sc::kErrConfig;
      if (i != b.motor && (driver_pins[i][0] == pin || driver_pins[i][1] == pin)) return sc::kErrConfig;
    }
  }
  return sc::kErrNone;
}

}  // namespace drv

#endif  // STEPCHOIR_DRIVER_POWER_H

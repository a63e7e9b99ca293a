// step_driver.cpp: StepDriver on the AVR, and the board's set of drivers (drivers::): their
// power state (driver_power.h) from the idle settings, the notes and kMsgDriverAct.
#include "step_driver.h"

#include <util/delay.h>

#include "boards/board.h"
#include "config.h"
#include "driver_power.h"
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

void StepDriver::sleep(bool on) { pio::write(pins_.sleep, !on); }

void StepDriver::reset() {
  pio::write(pins_.reset, false);
  _delay_us(10);  // A4988, DRV8825: a few hundred ns suffice
  pio::write(pins_.reset, true);
}

namespace {
// Called from: set_power_pins. Moves one of a driver's power pins (`slot`) to `to`, an output
// high; the old pin, unless the driver keeps using it (`other`: its other power pin, new), goes
// back to an input.
__attribute__((noinline)) void repin(board::Pin &slot, board::Pin to, board::Pin other) {
  if (!board::same_pin(slot, to) && !board::same_pin(slot, other)) pio::input(slot, false);
  slot = to;
  pio::output(slot, true);
}
}  // namespace

void StepDriver::set_power_pins(board::Pin sleep_pin, board::Pin reset_pin) {
  repin(pins_.sleep, sleep_pin, reset_pin);
  repin(pins_.reset, reset_pin, sleep_pin);
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

namespace {
const uint8_t kMotors = board::active::kMotorCount;
StepDriver g_drivers[kMotors];
drv::Power g_power[kMotors];  // zero: idle none, no wake time, awake
uint32_t g_last_poll;         // board time of the last idle check

// True when motor i shares motor m's ENABLE pin (itself included).
inline bool same_enable(uint8_t i, uint8_t m) { return i == m || board::active::kSharedEnable; }

// Motor m's driver is powered down: asleep, or its ENABLE off.
bool down(uint8_t m) { return (g_power[m].flags & drv::kAsleep) || !g_drivers[m].enabled(); }

// Called from: the drivers:: functions below. Wakes motor m's driver if it is powered down:
// ENABLE on (every motor on a shared one), SLEEP high. Each driver woken may step its wake time
// later (drv::woke).
void wake(uint8_t m) {
  const bool off = !g_drivers[m].enabled();
  if (!off && !(g_power[m].flags & drv::kAsleep)) return;
  if (off) {
    for (uint8_t i = 0; i < kMotors; ++i)
      if (same_enable(i, m)) g_drivers[i].enable(true);
    _delay_us(6);  // a TB6600 wants ENA 5 us before DIR moves
  }
  g_drivers[m].sleep(false);
  g_power[m].flags &= (uint8_t)~drv::kAsleep;
  const uint32_t now = sched::now();  // read after the pins changed: the wake time counts from it
  for (uint8_t i = 0; i < kMotors; ++i)
    if (i == m || (off && same_enable(i, m))) drv::woke(g_power[i], now);
  drivers::g_unsure = 0xFF;
}

// Called from: poll, act. ENABLE off for motor m (every motor on a shared one).
void disable_group(uint8_t m) {
  for (uint8_t i = 0; i < kMotors; ++i)
    if (same_enable(i, m)) g_drivers[i].enable(false);
  drivers::g_unsure = 0xFF;
}
}  // namespace

namespace drivers {

uint8_t g_unsure = 0xFF;
// A kMsgDriver or kMsgDriverAct was taken: poll has idle times and holds to look after.
bool g_power_used = false;

// Called from: setup(). Pins of every socket, then the step scheduler.
void begin() {
  sched::Wiring w[kMotors];
  for (uint8_t m = 0; m < kMotors; ++m) {
    const board::MotorPins &p = board::active::kMotors[m];
    g_drivers[m].begin(p, board::active::kEnableActiveLow);
    w[m] = {p.step, p.dir, p.min_switch, p.max_switch};
  }
  sched::init(kMotors, w);
}

uint8_t configure(const sc::ConfigBody &c) {
  StepDriver &d = g_drivers[c.motor];
  if (!d.set_microsteps(c.driver, c.microsteps)) return sc::kErrConfig;
  sched::Motion m;
  m.travel_steps = c.travel_steps;
  m.pulse_ticks = (uint16_t)(c.pulse_us * (F_CPU / 1000000ul));
  m.switch_active_high = c.endstop_active_high;
  m.start_period_q8 = c.start_period_q8;
  m.ramp_q8 = c.accel_q8;
  sched::set_motion(c.motor, m);
  return sc::kErrNone;
}

uint8_t configure_power(const sc::DriverBody &b) {
  int8_t in_use[kMotors][2];
  for (uint8_t i = 0; i < kMotors; ++i) {
    in_use[i][0] = g_drivers[i].sleep_pin().arduino;
    in_use[i][1] = g_drivers[i].reset_pin().arduino;
  }
  const uint8_t rc = drv::check_driver(b, board::active::kMotors, kMotors, board::active::kPinCount, in_use);
  if (rc != sc::kErrNone) return rc;
  StepDriver &d = g_drivers[b.motor];
  drv::Power &p = g_power[b.motor];
  const board::Pin sleep = board::pin_from_map(board::active::kPinMap, board::active::kPinCount, b.sleep_pin);
  const board::Pin reset = board::pin_from_map(board::active::kPinMap, board::active::kPinCount, b.reset_pin);
  // The driver wakes where SLEEP was low (kept, moved or no longer wired: the carrier's pull-up
  // takes it high) or is a new pin.
  const bool rises = (p.flags & drv::kAsleep) || (sleep.wired() && !board::same_pin(sleep, d.sleep_pin()));
  d.set_power_pins(sleep, reset);
  const uint32_t now = sched::now();
  drv::set_idle(p, b.idle, b.idle_ms, b.wake_us, F_CPU, now);
  p.flags &= (uint8_t)~drv::kAsleep;
  if (rises) drv::woke(p, now);
  g_unsure = 0xFF;
  g_power_used = true;
  return sc::kErrNone;
}

uint8_t act(uint8_t m, uint8_t action) {
  StepDriver &d = g_drivers[m];
  drv::Power &p = g_power[m];
  if (action > sc::kActReset || (action == sc::kActSleep && !d.sleep_pin().wired()) ||
      (action == sc::kActReset && !d.reset_pin().wired()))
    return sc::kErrConfig;
  if (action == sc::kActWake) {
    if (down(m)) {
      wake(m);
    } else {  // awake already: its silence counts from now
      drv::stir(p, sched::now());
    }
    return sc::kErrNone;
  }
  // Refused while a timed note of a motor it powers down is queued or taken (its driver must be
  // awake on the note's time, which the note's wake at queueing made sure of).
  const uint32_t now = sched::now();
  for (uint8_t i = 0; i < kMotors; ++i)
    if ((i == m || (action == sc::kActDisable && same_enable(i, m))) && drv::held(g_power[i], now))
      return sc::kErrConfig;
  // Silence first, and wait until the motors are silent: a sounding motor takes the command at
  // a visit or at its next edge (within cfg::kVisitMarginTicks, 256 us), which still sounds.
  uint8_t silencing = 0;
  for (uint8_t i = 0; i < kMotors; ++i)
    if (i == m || (action == sc::kActDisable && same_enable(i, m))) {
      sched::set_period(i, sc::kPeriodSilent);
      silencing |= (uint8_t)(1u << i);
    }
  while (sched::sounding() & silencing) {
  }
  if (action == sc::kActSleep) {
    d.sleep(true);
    p.flags |= drv::kAsleep;
  } else if (action == sc::kActDisable) {
    disable_group(m);
  } else {
    d.reset();
    drv::woke(p, sched::now());
  }
  g_unsure = 0xFF;
  g_power_used = true;
  return sc::kErrNone;
}

bool ready_time(uint8_t m, uint32_t *ready) {
  wake(m);
  if ((g_power[m].flags & drv::kWaking) && drv::waking(g_power[m], sched::now(), ready)) return true;
  g_unsure &= (uint8_t)~(1u << m);  // awake and ready: the next live notes need not ask
  return false;
}

uint32_t entry_time(uint8_t m, uint32_t period_q8, uint32_t at) {
  if (period_q8 == sc::kPeriodSilent) return at;  // a silence needs no driver, and holds none
  uint32_t ready;
  if (ready_time(m, &ready) && (int32_t)(at - ready) < 0) at = ready;
  drv::hold(g_power[m], at);
  return at;
}

}  // namespace drivers

namespace {
// Called from: drivers::poll, once a millisecond (out of line: the pass that only reads the
// clock saves no registers). Powers down the drivers whose motors have been idle long enough.
__attribute__((noinline)) void check_idle(uint32_t now) {
  const uint8_t sounding = sched::sounding();
  bool all_idle = true, any_disable = false;  // a shared ENABLE: every motor idle, one asks disable
  for (uint8_t m = 0; m < kMotors; ++m) {
    drv::Power &p = g_power[m];
    if (down(m)) {
      if (drv::held(p, now)) wake(m);  // a queued note needs it (queueing woke it; acts wait for it)
      continue;
    }
    const bool due = drv::idle_due(p, sounding & (1u << m), now);
    all_idle = all_idle && due;
    if (!due) continue;
    if (p.idle == sc::kIdleSleep) {
      g_drivers[m].sleep(true);
      p.flags |= drv::kAsleep;
      drivers::g_unsure = 0xFF;
    } else if (board::active::kSharedEnable) {
      any_disable = true;  // disable_group below, once every motor on it is idle
    } else {
      g_drivers[m].enable(false);
      drivers::g_unsure = 0xFF;
    }
  }
  if (board::active::kSharedEnable && all_idle && any_disable) disable_group(0);
}
}  // namespace

namespace drivers {

void poll() {
  if (!g_power_used) return;  // no driver message yet: nothing to power down (one load a pass)
  const uint32_t now = sched::now();
  if ((uint32_t)(now - g_last_poll) < cfg::kDriverPollTicks) return;  // elapsed: no wrap to fear
  g_last_poll = now;
  check_idle(now);
}

void disable_all() {
  for (uint8_t m = 0; m < kMotors; ++m) {
    g_drivers[m].enable(false);
    g_power[m].flags &= (uint8_t)~drv::kHeld;  // the queue is emptied with it
  }
  g_unsure = 0xFF;
}

void release(uint8_t mask) {
  const uint32_t now = sched::now();
  for (drv::Power *p = g_power; p != g_power + kMotors; ++p, mask = (uint8_t)(mask >> 1))
    if (mask & 1) drv::release(*p, now);
}

bool any_enabled() {
  for (uint8_t m = 0; m < kMotors; ++m)
    if (g_drivers[m].enabled()) return true;
  return false;
}

}  // namespace drivers

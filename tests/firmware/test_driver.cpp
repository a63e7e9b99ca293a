// test_driver.cpp: a driver's idle power-down, wake time and kMsgDriver checks
// (firmware/stepchoir/driver_power.h), on the host, against the real board tables.
#include <catch2/catch.hpp>

#include "boards/mega_ramps_14.h"
#include "boards/uno_cnc_shield_v3.h"
#include "driver_power.h"

namespace {

const uint32_t kF = 16000000;        // F_CPU
const uint32_t kMs = kF / 1000;      // ticks a millisecond

// A driver set to `idle` after idle_ms, waking in wake_us, at board time `now`.
drv::Power power(uint8_t idle, uint16_t idle_ms, uint16_t wake_us, uint32_t now) {
  drv::Power p{};
  drv::set_idle(p, idle, idle_ms, wake_us, kF, now);
  return p;
}

// A kMsgDriver body for motor m.
sc::DriverBody body(uint8_t m, int8_t sleep_pin, int8_t reset_pin, uint8_t idle = sc::kIdleNone,
                    uint16_t wake_us = 1000) {
  return sc::DriverBody{m, sleep_pin, reset_pin, idle, 100, wake_us};
}

// No other driver uses a SLEEP or RESET pin.
int8_t g_free[5][2] = {{-1, -1}, {-1, -1}, {-1, -1}, {-1, -1}, {-1, -1}};

uint8_t check_uno(const sc::DriverBody &b, const int8_t (*in_use)[2] = g_free) {
  namespace u = board::uno_cnc_shield_v3;
  return drv::check_driver(b, u::kMotors, u::kMotorCount, u::kPinCount, in_use);
}

}  // namespace

TEST_CASE("driver: idle sleep falls due idle_ms after the motor fell silent - never while it sounds", "[driver]") {
  const uint32_t t0 = 0xFFFF0000u;  // across the clock's wrap
  drv::Power p = power(sc::kIdleSleep, 100, 1000, t0);
  CHECK_FALSE(drv::idle_due(p, true, t0 + 500 * kMs));  // sounding for half a second
  // silent from the next check on: the silence counts from there, not from the last sounding check
  const uint32_t silent = t0 + 501 * kMs;
  CHECK_FALSE(drv::idle_due(p, false, silent));
  CHECK_FALSE(drv::idle_due(p, false, silent + 100 * kMs - 1));
  CHECK(drv::idle_due(p, false, silent + 100 * kMs));
  CHECK(drv::idle_due(p, false, silent + 100 * kMs + 1));  // stays due
  CHECK_FALSE(drv::idle_due(p, true, silent + 200 * kMs));  // until it plays again
  CHECK_FALSE(drv::idle_due(p, false, silent + 201 * kMs));
}

TEST_CASE("driver: idle none is never due - idle disable is", "[driver]") {
  drv::Power none = power(sc::kIdleNone, 0, 0, 0);
  drv::Power off = power(sc::kIdleDisable, 0, 0, 0);
  for (uint32_t t : {0u, 1u, 1000u * kMs}) {
    CHECK_FALSE(drv::idle_due(none, false, t));
    CHECK(drv::idle_due(off, false, t));
  }
}

TEST_CASE("driver: a queued note holds the driver awake until its time", "[driver]") {
  drv::Power p = power(sc::kIdleSleep, 10, 1000, 0);
  drv::hold(p, 300 * kMs);  // a note at 300 ms, queued at 0
  CHECK_FALSE(drv::idle_due(p, false, 100 * kMs));
  CHECK_FALSE(drv::idle_due(p, false, 299 * kMs));
  CHECK_FALSE(drv::idle_due(p, false, 300 * kMs));  // held until then, then idle_ms of silence
  CHECK_FALSE(drv::idle_due(p, false, 309 * kMs));
  CHECK(drv::idle_due(p, false, 310 * kMs));
  // the note sounded meanwhile and ended at 400 ms: the silence counts from the check after
  drv::Power q = power(sc::kIdleSleep, 10, 1000, 0);
  drv::hold(q, 300 * kMs);
  CHECK_FALSE(drv::idle_due(q, true, 350 * kMs));
  CHECK_FALSE(drv::idle_due(q, false, 401 * kMs));
  CHECK_FALSE(drv::idle_due(q, false, 410 * kMs));
  CHECK(drv::idle_due(q, false, 411 * kMs));
}

TEST_CASE("driver: a released hold no longer keeps the driver awake - idle_ms from the release", "[driver]") {
  drv::Power p = power(sc::kIdleSleep, 10, 1000, 0);
  drv::hold(p, 5000 * kMs);  // a note 5 s ahead, dropped at 100 ms (silence)
  CHECK_FALSE(drv::idle_due(p, false, 50 * kMs));
  drv::release(p, 100 * kMs);
  CHECK_FALSE(drv::held(p, 101 * kMs));
  CHECK_FALSE(drv::idle_due(p, false, 109 * kMs));
  CHECK(drv::idle_due(p, false, 110 * kMs));
}

TEST_CASE("driver: a hold whose time came is dropped, even while the motor sounds", "[driver]") {
  drv::Power p = power(sc::kIdleSleep, 10, 1000, 0);
  drv::hold(p, 50 * kMs);
  CHECK(drv::held(p, 49 * kMs));
  CHECK_FALSE(drv::idle_due(p, true, 60 * kMs));  // the note sounds: its hold is over
  CHECK((p.flags & drv::kHeld) == 0);
  CHECK_FALSE(drv::held(p, 61 * kMs));
  drv::hold(p, 100 * kMs);
  CHECK_FALSE(drv::held(p, 100 * kMs));
}

TEST_CASE("driver: a woken driver is waking for wake_us - a driver without a wake time is ready at once", "[driver]") {
  drv::Power p = power(sc::kIdleSleep, 100, 1700, 0);
  p.flags |= drv::kAsleep | drv::kIdle;
  const uint32_t t = 0xFFFFFFF0u;
  drv::woke(p, t);
  uint32_t ready = 0;
  REQUIRE(drv::waking(p, t + 1, &ready));
  CHECK(ready == t + 1700u * 16u);
  CHECK((p.flags & drv::kIdle) == 0);
  CHECK(drv::waking(p, ready - 1, &ready));
  CHECK_FALSE(drv::waking(p, t + 1700u * 16u, &ready));
  CHECK((p.flags & drv::kWaking) == 0);
  drv::Power q = power(sc::kIdleNone, 0, 0, 0);
  drv::woke(q, 5);
  CHECK_FALSE(drv::waking(q, 5, &ready));
  // woken while a queued note holds it: still held until the note's time
  drv::Power h = power(sc::kIdleSleep, 10, 1000, 0);
  drv::hold(h, 50 * kMs);
  drv::woke(h, 1 * kMs);
  CHECK_FALSE(drv::idle_due(h, false, 40 * kMs));
  CHECK(drv::idle_due(h, false, 60 * kMs));
}

TEST_CASE("driver: kMsgDriver values the Uno takes", "[driver]") {
  CHECK(check_uno(body(0, 14, 15, sc::kIdleSleep)) == sc::kErrNone);      // A0 and A1
  CHECK(check_uno(body(3, -1, -1, sc::kIdleDisable, 5)) == sc::kErrNone);  // the shared ENABLE
  CHECK(check_uno(body(1, 19, -1, sc::kIdleSleep, sc::kWakeUsMax)) == sc::kErrNone);
  CHECK(check_uno(body(2, -1, 16, sc::kIdleNone, 0)) == sc::kErrNone);
  // the same motor may keep its own pins
  int8_t own[5][2] = {{14, 15}, {-1, -1}, {-1, -1}, {-1, -1}, {-1, -1}};
  CHECK(check_uno(body(0, 14, 15, sc::kIdleSleep), own) == sc::kErrNone);
  CHECK(check_uno(body(0, 15, 14, sc::kIdleSleep), own) == sc::kErrNone);  // swapped
}

TEST_CASE("driver: kMsgDriver values the Uno refuses with config", "[driver]") {
  CHECK(check_uno(body(0, 20, -1)) == sc::kErrConfig);   // the Uno has pins 0-19
  CHECK(check_uno(body(0, -1, 100)) == sc::kErrConfig);
  CHECK(check_uno(body(0, -2, -1)) == sc::kErrConfig);
  CHECK(check_uno(body(0, 0, -1)) == sc::kErrConfig);    // UART RX
  CHECK(check_uno(body(0, -1, 1)) == sc::kErrConfig);    // UART TX
  for (int8_t used : {2, 5, 8, 9, 10, 11, 3, 6, 4, 7, 12, 13})  // every STEP, DIR, ENABLE and switch pin
    for (uint8_t m = 0; m < 4; ++m) {
      INFO("pin " << int(used) << " for motor " << int(m));
      CHECK(check_uno(body(m, used, -1)) == sc::kErrConfig);
      CHECK(check_uno(body(m, -1, used)) == sc::kErrConfig);
    }
  CHECK(check_uno(body(0, 14, 14)) == sc::kErrConfig);  // one pin for both
  CHECK(check_uno(body(0, -1, 15, sc::kIdleSleep)) == sc::kErrConfig);  // idle sleep without SLEEP
  CHECK(check_uno(body(0, 14, -1, 3)) == sc::kErrConfig);
  CHECK(check_uno(body(0, 14, -1, sc::kIdleSleep, sc::kWakeUsMax + 1)) == sc::kErrConfig);
  int8_t taken[5][2] = {{-1, -1}, {14, 15}, {-1, -1}, {-1, -1}, {-1, -1}};  // motor 1's SLEEP and RESET
  CHECK(check_uno(body(0, 14, -1), taken) == sc::kErrConfig);
  CHECK(check_uno(body(0, -1, 14), taken) == sc::kErrConfig);
  CHECK(check_uno(body(2, 16, 15), taken) == sc::kErrConfig);
  CHECK(check_uno(body(2, 16, 17), taken) == sc::kErrNone);  // pins no one uses
}

TEST_CASE("driver: the Mega's pins reach 69 - its motors' pins are taken", "[driver]") {
  namespace g = board::mega_ramps_14;
  auto check = [](const sc::DriverBody &b) { return drv::check_driver(b, g::kMotors, g::kMotorCount, g::kPinCount, g_free); };
  CHECK(check(body(4, 69, 68, sc::kIdleSleep)) == sc::kErrNone);
  CHECK(check(body(4, 70, -1)) == sc::kErrConfig);
  for (int8_t used : {54, 55, 38, 3, 2, 60, 61, 56, 14, 15, 46, 48, 62, 18, 19, 26, 28, 24, 36, 34, 30}) {
    INFO("pin " << int(used));
    CHECK(check(body(0, used, -1)) == sc::kErrConfig);
  }
}

TEST_CASE("driver: an Arduino pin number maps to its port and bit through the board's pin map", "[driver]") {
  namespace u = board::uno_cnc_shield_v3;
  namespace g = board::mega_ramps_14;
  const board::Pin a0 = board::pin_from_map(u::kPinMap, u::kPinCount, 14);
  CHECK(a0.arduino == 14);
  CHECK(a0.port == 'C');
  CHECK(a0.bit == 0);
  const board::Pin a15 = board::pin_from_map(g::kPinMap, g::kPinCount, 69);
  CHECK(a15.port == 'K');
  CHECK(a15.bit == 7);
  CHECK(board::pin_from_map(g::kPinMap, g::kPinCount, 14).port == 'J');  // D14 is PJ1
  CHECK_FALSE(board::pin_from_map(u::kPinMap, u::kPinCount, 20).wired());
  CHECK_FALSE(board::pin_from_map(u::kPinMap, u::kPinCount, -1).wired());
}

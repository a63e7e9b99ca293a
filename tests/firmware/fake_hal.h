// fake_hal.h: the recording hal (see fake_hal.cpp).
#ifndef STEPCHOIR_TESTS_FAKE_HAL_H
#define STEPCHOIR_TESTS_FAKE_HAL_H

#include <array>
#include <cstdint>
#include <vector>

#include "hal.h"

struct FakeHal {
  enum Kind { kSet, kQueued, kStop, kSilence };  // kSilence: motor holds the mask
  struct Call {
    Kind kind;
    uint8_t motor;
    uint32_t period_q8;
    uint32_t at_ticks;
  };
  uint8_t motors = 4;
  uint32_t now = 1000;
  std::array<uint32_t, 8> period{};
  uint8_t queued = 0;        // entries in the queue (the step ISR's side is the test's)
  uint8_t late = 0, late_motor = 0;  // what hal::late_entries() reports
  std::vector<Call> calls;
  std::vector<sc::ConfigBody> configs;
  std::vector<sc::DriverBody> drivers;          // kMsgDriver bodies hal::configure_driver took
  std::vector<sc::DriverActBody> acts;          // kMsgDriverAct calls
  uint8_t driver_rc = sc::kErrNone;             // what both return
  std::vector<uint8_t> sent;                   // encoded reply bytes
  std::vector<std::vector<uint8_t>> replies;   // reply payloads
  std::array<uint8_t, 64> eeprom = [] {        // erased, as a new board's
    std::array<uint8_t, 64> e{};
    e.fill(0xFF);
    return e;
  }();
  int eeprom_writes = 0;                        // hal::eeprom_write calls
  std::vector<sc::MoveBody> moves;              // moves hal::move started
  uint8_t moving = 0;                           // what hal::moving() reports (bit a motor)
  std::vector<sc::MoveDoneBody> ended;          // what hal::move_ended hands out, first first
  std::array<int32_t, 8> position{};            // what hal::set_position set
  std::array<uint16_t, 8> reversals{};          // each motor's, as hal::motor_status reports them
  void reset() { *this = FakeHal(); }
};

extern FakeHal g_hal;

#endif  // STEPCHOIR_TESTS_FAKE_HAL_H

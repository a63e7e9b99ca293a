// test_commands_motors.cpp: the firmware's command layer (host build) on the commands that set
// up and move a motor: config range-checked before it reaches the driver, driver frames refused
// or answered, and moves checked, refused while the motor is busy and answered when they end.
// Built into test_firmware.
#include <catch2/catch.hpp>

#include <cstring>

#include "command_feed.h"

TEST_CASE("config is range-checked before it reaches the driver") {
  auto &c = fresh();
  sc::ConfigBody b{};
  b.motor = 1;
  b.driver = sc::kDriverDrv8825;
  b.microsteps = 16;
  b.travel_steps = 1000;
  b.min_period_q8 = sc::kPeriodQ8Min;
  b.max_period_q8 = sc::kPeriodQ8Max;
  b.pulse_us = 2;
  auto send = [&](const sc::ConfigBody &x) {
    std::vector<uint8_t> p(1 + sizeof x);
    p[0] = sc::kMsgConfig;
    memcpy(&p[1], &x, sizeof x);
    g_hal.replies.clear();
    feed(c, wire(p));
  };
  send(b);
  CHECK(g_hal.replies.empty());
  CHECK(g_hal.configs.size() == 1);
  auto bad = b;
  bad.pulse_us = 30;
  send(bad);
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrConfig);
  bad = b;
  bad.motor = 7;
  send(bad);
  CHECK(g_hal.replies[0][1] == sc::kErrMotor);
  bad = b;
  bad.driver = sc::kDriverA4988;
  bad.microsteps = 32;  // the A4988 has no 1/32
  send(bad);
  CHECK(g_hal.replies[0][1] == sc::kErrConfig);
  bad = b;
  bad.travel_steps = sc::kMaxTravelSteps + 1;  // would overflow the signed position
  send(bad);
  CHECK(g_hal.replies[0][1] == sc::kErrConfig);
  bad = b;
  bad.start_period_q8 = 2000000;
  bad.accel_q8 = sc::kPeriodQ8Max + 1;  // a ramp step longer than any period
  send(bad);
  CHECK(g_hal.replies[0][1] == sc::kErrConfig);
  // the configured range now limits set-period
  b.max_period_q8 = 1000000;
  send(b);
  std::vector<uint8_t> p(4);
  sc::put_entry(&p[0], 1, 2000000);
  g_hal.replies.clear();
  feed(c, wire(p));
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrPeriodRange);
}

TEST_CASE("driver frames: a wrong length or motor is refused before the board sees them - its refusal is answered") {
  auto &c = fresh();
  uint8_t p[16];
  const uint8_t n = sc::put_driver(p, sc::DriverBody{1, 14, -1, sc::kIdleSleep, 100, 1000});
  std::vector<uint8_t> good(p, p + n);
  feed(c, wire(good));
  REQUIRE(g_hal.drivers.size() == 1);
  CHECK(g_hal.replies.empty());
  auto longer = good;
  longer.push_back(0);
  feed(c, wire(longer));
  feed(c, wire({good.begin(), good.end() - 1}));
  auto motor = good;
  motor[1] = 4;  // a 4-motor board
  feed(c, wire(motor));
  feed(c, wire({sc::kMsgDriverAct, 4, sc::kActWake}));
  feed(c, wire({sc::kMsgDriverAct, 0}));
  CHECK(g_hal.drivers.size() == 1);
  CHECK(g_hal.acts.empty());
  REQUIRE(g_hal.replies.size() == 5);
  CHECK(g_hal.replies[0][1] == sc::kErrLength);
  CHECK(g_hal.replies[0][2] == sc::kMsgDriver);
  CHECK(g_hal.replies[1][1] == sc::kErrLength);
  CHECK(g_hal.replies[2][1] == sc::kErrMotor);
  CHECK(g_hal.replies[3][1] == sc::kErrMotor);
  CHECK(g_hal.replies[3][2] == sc::kMsgDriverAct);
  CHECK(g_hal.replies[4][1] == sc::kErrLength);
  // the board's own refusal (a pin it lacks, say) is answered and counted as a bad frame
  g_hal.driver_rc = sc::kErrConfig;
  const uint16_t bad = c.frames_bad();
  feed(c, wire(good));
  feed(c, wire({sc::kMsgDriverAct, 0, sc::kActReset}));
  REQUIRE(g_hal.replies.size() == 7);
  CHECK(g_hal.replies[5][1] == sc::kErrConfig);
  CHECK(g_hal.replies[6][1] == sc::kErrConfig);
  CHECK(g_hal.replies[6][2] == sc::kMsgDriverAct);
  CHECK(c.frames_bad() == bad + 2);
}

TEST_CASE("a move is checked, refused while the motor sounds or moves, and answered when it ends") {
  auto &c = fresh();
  const sc::MoveBody good{1, sc::kMoveUp | sc::kMoveToSwitch, 4000, 400, 3200, 16000};
  auto move = [&](sc::MoveBody b) {
    std::vector<uint8_t> p(1 + sizeof b);
    sc::put_move(p.data(), b);
    g_hal.replies.clear();
    feed(c, wire(p));
    return g_hal.replies.empty() ? uint8_t(sc::kErrNone) : g_hal.replies.back()[1];
  };
  // Out of range: each field alone.
  sc::MoveBody b = good;
  b.motor = 4;
  CHECK(move(b) == sc::kErrMotor);
  const auto bad = [&](void (*spoil)(sc::MoveBody &)) {
    sc::MoveBody x = good;
    spoil(x);
    return move(x);
  };
  CHECK(bad([](sc::MoveBody &x) { x.flags = 0x04; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.steps = 0; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.steps = sc::kMaxTravelSteps + 1; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.speed_min = sc::kMoveSpeedMin - 1; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.speed_max = sc::kMoveSpeedMax + 1; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.speed_min = 3300; }) == sc::kErrConfig);  // above speed_max
  CHECK(bad([](sc::MoveBody &x) { x.accel = 0; }) == sc::kErrConfig);
  CHECK(bad([](sc::MoveBody &x) { x.accel = sc::kMoveAccelMax + 1; }) == sc::kErrConfig);
  CHECK(g_hal.moves.empty());
  // A sounding motor, a timed entry waiting: busy.
  g_hal.period[1] = 9309091;
  CHECK(move(good) == sc::kErrBusy);
  g_hal.period[1] = 0;
  g_hal.queued = 1;
  CHECK(move(good) == sc::kErrBusy);
  g_hal.queued = 0;
  CHECK(move(good) == sc::kErrNone);
  REQUIRE(g_hal.moves.size() == 1);
  // While it moves: another move, a note, an at entry, config, set-position and driver-act are
  // refused; another motor plays.
  CHECK(move(good) == sc::kErrBusy);
  g_hal.replies.clear();
  feed(c, wire({0x90, 0xa3, 0x0b, 0x8e}));  // motor 1, 440 Hz
  feed_at(c, 5000, 1, 9309091);
  sc::ConfigBody cfg = {};
  cfg.motor = 1;
  std::vector<uint8_t> cp(1 + sizeof cfg, sc::kMsgConfig);
  std::memcpy(&cp[1], &cfg, sizeof cfg);
  feed(c, wire(cp));
  feed(c, wire({sc::kMsgSetPosition, 1, 0, 0, 0, 0}));
  feed(c, wire({sc::kMsgDriverAct, 2, sc::kActWake}));
  REQUIRE(g_hal.replies.size() == 5);
  for (const auto &r : g_hal.replies) CHECK(r[1] == sc::kErrBusy);
  CHECK(g_hal.calls.empty());
  CHECK(g_hal.acts.empty());
  feed(c, wire({0x80, 0xa3, 0x0b, 0x8e}));  // motor 0 plays
  CHECK(g_hal.period[0] == 9309091);
  // It ends: the reply comes at the next poll, once.
  g_hal.replies.clear();
  c.poll();
  CHECK(g_hal.replies.empty());
  g_hal.ended.push_back({1, sc::kMoveEndSwitch, -12, 3988});
  c.poll();
  c.poll();
  REQUIRE(g_hal.replies.size() == 1);
  sc::MoveDoneBody d{};
  REQUIRE(sc::get_move_done(g_hal.replies[0].data(), uint8_t(g_hal.replies[0].size()), &d));
  CHECK(d.motor == 1);
  CHECK(d.end == sc::kMoveEndSwitch);
  CHECK(d.position == -12);
  CHECK(d.steps == 3988u);
  // Then the motor takes notes and a position again.
  g_hal.replies.clear();
  feed(c, wire({sc::kMsgSetPosition, 1, 0x40, 0x06, 0, 0}));
  feed(c, wire({0x90, 0xa3, 0x0b, 0x8e}));
  CHECK(g_hal.replies.empty());
  CHECK(g_hal.position[1] == 1600);
  CHECK(g_hal.period[1] == 9309091);
}

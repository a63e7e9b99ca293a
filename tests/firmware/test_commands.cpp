// test_commands.cpp: the firmware's frame handling (host build) against the spec's vectors,
// adversarial byte streams, the watchdog and the timestamped queue.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "commands.h"
#include "fake_hal.h"
#include "vectors.h"

namespace {

// A fresh command layer on a fresh fake board.
cmd::Commands &fresh() {
  static cmd::Commands c;
  g_hal.reset();
  c = cmd::Commands();
  c.init();
  return c;
}

// Feeds bytes one at a time, as the main loop does.
void feed(cmd::Commands &c, const std::vector<uint8_t> &bytes) {
  for (uint8_t b : bytes) c.on_byte(b);
}

// Encodes a payload as the host would.
std::vector<uint8_t> wire(const std::vector<uint8_t> &payload) {
  std::vector<uint8_t> out(sc::kMaxFrameWire);
  out.resize(sc::encode_frame(payload.data(), uint8_t(payload.size()), out.data()));
  return out;
}

// Feeds one `at` frame: motor m to period p at board time t.
void feed_at(cmd::Commands &c, uint32_t t, uint8_t m, uint32_t p) {
  std::vector<uint8_t> pl(9);
  pl[0] = sc::kMsgAt;
  sc::put_u32(&pl[1], t);
  sc::put_entry(&pl[5], m, p);
  feed(c, wire(pl));
}

}  // namespace

TEST_CASE("firmware decodes every host-to-board spec vector and acts on it") {
  for (const auto &v : testvec::load()) {
    INFO("PROTOCOL.md:" << v.line << " " << v.kind);
    auto &c = fresh();
    feed(c, v.wire);
    if (v.payload[0] >= sc::kMsgCaps && v.payload[0] <= sc::kMsgMoveDone) {  // board-to-host messages are refused
      CHECK(c.frames_ok() == 0);
      CHECK(c.frames_bad() == 1);
      REQUIRE(g_hal.replies.size() == 1);
      CHECK(g_hal.replies[0][0] == sc::kMsgError);
      CHECK(g_hal.replies[0][1] == sc::kErrUnknownType);
      continue;
    }
    const auto motors = v.kind == "set-period" ? v.nums("motor") : std::vector<uint64_t>{};
    bool all_known = true;
    for (auto m : motors) all_known = all_known && m < g_hal.motors;
    CHECK(c.frames_ok() == (all_known ? 1u : 0u));  // a refused frame counts as bad
    CHECK(c.frames_bad() == (all_known ? 0u : 1u));
    if (v.kind == "set-period") {
      const auto periods = v.nums("period_q8");
      if (!all_known) {  // motor 4 on a 4-motor board: refused whole
        CHECK(g_hal.calls.empty());
        REQUIRE(g_hal.replies.size() == 1);
        CHECK(g_hal.replies[0][1] == sc::kErrMotor);
        continue;
      }
      REQUIRE(g_hal.calls.size() == motors.size());
      for (size_t i = 0; i < motors.size(); ++i) {
        CHECK(g_hal.calls[i].kind == FakeHal::kSet);
        CHECK(g_hal.calls[i].motor == motors[i]);
        CHECK(g_hal.calls[i].period_q8 == periods[i]);
      }
    } else if (v.kind == "hello") {
      REQUIRE(g_hal.replies.size() == 1);
      CHECK(g_hal.replies[0][0] == sc::kMsgCaps);
    } else if (v.kind == "stop-all") {
      REQUIRE(g_hal.calls.size() == 1);
      CHECK(g_hal.calls[0].kind == FakeHal::kStop);
    } else if (v.kind == "status-req") {
      REQUIRE(g_hal.replies.size() == 1);
      CHECK(g_hal.replies[0][0] == sc::kMsgStatus);
      CHECK(g_hal.replies[0].size() == 1 + sizeof(sc::StatusHead) + 4 * sizeof(sc::StatusMotor));
    } else if (v.kind == "clock-req") {
      REQUIRE(g_hal.replies.size() == 1);
      CHECK(g_hal.replies[0][1] == v.num("seq"));
      CHECK(sc::get_u32(&g_hal.replies[0][2]) == g_hal.now);
    } else if (v.kind == "config") {
      REQUIRE(g_hal.configs.size() == 1);
      CHECK(g_hal.configs[0].motor == v.num("motor"));
      CHECK(g_hal.configs[0].microsteps == v.num("microsteps"));
      CHECK(g_hal.configs[0].travel_steps == v.num("travel_steps"));
      CHECK(g_hal.replies.empty());
    } else if (v.kind == "at") {
      CHECK(c.queue_used() == 1);  // queued for the step ISR, with its time
      REQUIRE(g_hal.calls.size() == 1);
      CHECK(g_hal.calls[0].kind == FakeHal::kQueued);
      CHECK(g_hal.calls[0].at_ticks == v.num("ticks"));
      CHECK(g_hal.calls[0].period_q8 == v.num("period_q8"));
    } else if (v.kind == "driver") {
      REQUIRE(g_hal.drivers.size() == 1);
      const sc::DriverBody &b = g_hal.drivers[0];
      CHECK(b.motor == v.num("motor"));
      CHECK(b.sleep_pin == std::stoi(v.str("sleep_pin")));
      CHECK(b.reset_pin == std::stoi(v.str("reset_pin")));
      CHECK(b.idle == v.num("idle"));
      CHECK(b.idle_ms == v.num("idle_ms"));
      CHECK(b.wake_us == v.num("wake_us"));
      CHECK(g_hal.replies.empty());
    } else if (v.kind == "driver-act") {
      REQUIRE(g_hal.acts.size() == 1);
      CHECK(g_hal.acts[0].motor == v.num("motor"));
      CHECK(g_hal.acts[0].action == v.num("action"));
    } else if (v.kind == "heartbeat" || v.kind == "watchdog") {
      CHECK(g_hal.calls.empty());
      CHECK(g_hal.replies.empty());
    } else if (v.kind == "id-req") {  // a new board: erased EEPROM, no id
      REQUIRE(g_hal.replies.size() == 1);
      std::vector<uint8_t> none(1 + sc::kBoardIdBytes, 0);
      none[0] = sc::kMsgId;
      CHECK(g_hal.replies[0] == none);
    } else if (v.kind == "move") {
      REQUIRE(g_hal.moves.size() == 1);
      const sc::MoveBody &b = g_hal.moves[0];
      CHECK(b.motor == v.num("motor"));
      CHECK(b.flags == v.num("flags"));
      CHECK(b.steps == v.num("steps"));
      CHECK(b.speed_min == v.num("speed_min"));
      CHECK(b.speed_max == v.num("speed_max"));
      CHECK(b.accel == v.num("accel"));
      CHECK(g_hal.replies.empty());  // the reply comes when the move ends
    } else if (v.kind == "set-position") {
      CHECK(g_hal.position.at(v.num("motor")) == static_cast<int32_t>(std::stol(v.str("position"))));
      CHECK(g_hal.replies.empty());
    } else if (v.kind == "set-id") {
      REQUIRE(g_hal.replies.size() == 1);
      CHECK(g_hal.replies[0][0] == sc::kMsgId);
      CHECK(sc::get_board_id(&g_hal.replies[0][1]) == v.num("id"));
      CHECK(sc::get_board_id(&g_hal.eeprom[sc::kEepromIdAddr]) == v.num("id"));
    }
  }
}

TEST_CASE("the board id is kept in EEPROM - none, erased and a bad length are refused") {
  auto &c = fresh();
  std::vector<uint8_t> set{sc::kMsgSetId, 1, 2, 3, 4, 5, 6, 7, 8};
  feed(c, wire(set));
  feed(c, wire({sc::kMsgIdReq}));
  REQUIRE(g_hal.replies.size() == 2);
  CHECK(sc::get_board_id(&g_hal.replies[1][1]) == 0x0807060504030201ull);
  for (uint8_t fill : {0x00, 0xFF}) {
    g_hal.replies.clear();
    feed(c, wire({sc::kMsgSetId, fill, fill, fill, fill, fill, fill, fill, fill}));
    REQUIRE(g_hal.replies.size() == 1);
    CHECK(g_hal.replies[0] == std::vector<uint8_t>{sc::kMsgError, sc::kErrConfig, sc::kMsgSetId, 0});
  }
  g_hal.replies.clear();
  feed(c, wire({sc::kMsgSetId, 1, 2, 3}));
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrLength);
  CHECK(sc::get_board_id(&g_hal.eeprom[sc::kEepromIdAddr]) == 0x0807060504030201ull);  // kept
  CHECK(g_hal.eeprom_writes == 1);
}

TEST_CASE("the caps reply matches the spec's caps vector") {
  auto &c = fresh();
  feed(c, wire({sc::kMsgHello}));
  for (const auto &v : testvec::load())
    if (v.kind == "caps") CHECK(g_hal.sent == v.wire);
}

TEST_CASE("the status reply carries each motor's reversals - the head their wrapping sum - reset zeroes them") {
  auto &c = fresh();
  g_hal.reversals = {5, 0, 65535, 3};  // 4 motors: the sum 65543 wraps to 7
  const auto status = [&] {
    g_hal.replies.clear();
    feed(c, wire({sc::kMsgStatusReq}));
    REQUIRE(g_hal.replies.size() == 1);
    const std::vector<uint8_t> &r = g_hal.replies[0];
    REQUIRE(r.size() == 1 + sizeof(sc::StatusHead) + 4 * sizeof(sc::StatusMotor));
    sc::StatusHead h;
    std::memcpy(&h, &r[1], sizeof h);
    std::vector<uint64_t> counts{h.reversals};
    for (size_t m = 0; m < 4; ++m) {
      sc::StatusMotor s;
      std::memcpy(&s, &r[1 + sizeof h + m * sizeof s], sizeof s);
      CHECK(s.position_steps == int32_t(100 * m));  // the fake's positions: the record is in its place
      counts.push_back(s.reversals);
    }
    return counts;  // the head's total, then each motor's
  };
  CHECK(status() == std::vector<uint64_t>{7, 5, 0, 65535, 3});
  feed(c, wire({sc::kMsgResetCounters}));
  CHECK(status() == std::vector<uint64_t>{0, 0, 0, 0, 0});
}

TEST_CASE("a chord with one bad entry plays nothing") {
  auto &c = fresh();
  std::vector<uint8_t> p(8);
  sc::put_entry(&p[0], 0, 9309091);
  sc::put_entry(&p[4], 1, 1000);  // below kPeriodQ8Min
  feed(c, wire(p));
  CHECK(g_hal.calls.empty());
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrPeriodRange);
  CHECK(c.last_error() == sc::kErrPeriodRange);
}

TEST_CASE("wrong lengths are refused with the message type named") {
  auto &c = fresh();
  feed(c, wire({sc::kMsgHello, 0}));
  feed(c, wire({sc::kMsgClockReq}));
  feed(c, wire({0x80, 1, 2}));  // 3-byte entry
  feed(c, wire({0x55}));
  REQUIRE(g_hal.replies.size() == 4);
  CHECK(g_hal.replies[0][1] == sc::kErrLength);
  CHECK(g_hal.replies[0][2] == sc::kMsgHello);
  CHECK(g_hal.replies[1][1] == sc::kErrLength);
  CHECK(g_hal.replies[2][1] == sc::kErrLength);
  CHECK(g_hal.replies[3][1] == sc::kErrUnknownType);
  CHECK(g_hal.calls.empty());
}

TEST_CASE("random byte streams never crash the command layer and it resyncs") {
  std::mt19937 rng(99);
  for (int trial = 0; trial < 300; ++trial) {
    auto &c = fresh();
    std::vector<uint8_t> junk(size_t(rng() % 3000));
    for (auto &b : junk) b = uint8_t(rng() % 7 == 0 ? 0 : rng());
    feed(c, junk);
    g_hal.calls.clear();
    g_hal.replies.clear();
    const uint32_t before = c.frames_ok();
    feed(c, wire({sc::kMsgHeartbeat}));  // may be eaten by leftover garbage
    feed(c, wire({sc::kMsgHello}));
    INFO("trial " << trial);
    CHECK(c.frames_ok() >= before + 1);
    bool caps = false;
    for (const auto &r : g_hal.replies) caps = caps || r[0] == sc::kMsgCaps;
    CHECK(caps);
  }
}

TEST_CASE("garbage is counted as bad frames") {
  auto &c = fresh();
  auto f = wire({sc::kMsgHeartbeat});
  f[1] ^= 0x40;  // corrupt the type byte
  feed(c, f);
  CHECK(c.frames_bad() == 1);
  CHECK(c.frames_ok() == 0);
  CHECK(c.last_error() == sc::kErrCrc);
  std::vector<uint8_t> too_long(200, 0x11);
  too_long.push_back(0);
  feed(c, too_long);
  CHECK(c.frames_bad() == 2);
  CHECK(c.last_error() == sc::kErrFrameTooLong);
}

TEST_CASE("watchdog stops everything once when frames stop - and re-arms when music resumes") {
  auto &c = fresh();
  std::vector<uint8_t> p(4);
  sc::put_entry(&p[0], 0, 9309091);
  feed(c, wire(p));
  c.poll();  // the main loop polls after every batch of bytes: the frame's time is taken there
  const uint32_t timeout = cmd::ms_to_ticks(cfg::kWatchdogDefaultMs, F_CPU);
  g_hal.now += timeout - 10;
  c.poll();
  CHECK(g_hal.period[0] == 9309091);
  g_hal.now += 20;
  c.poll();
  CHECK(g_hal.period[0] == 0);
  CHECK(c.watchdog_tripped());
  CHECK(c.last_error() == sc::kErrWatchdog);
  g_hal.calls.clear();
  c.poll();
  CHECK(g_hal.calls.empty());  // once
  feed(c, wire({sc::kMsgHeartbeat}));
  CHECK(c.watchdog_tripped());  // still reported to a status request after the stop
  feed(c, wire(p));
  CHECK_FALSE(c.watchdog_tripped());
  c.poll();
  g_hal.now += timeout + 10;
  c.poll();
  CHECK(c.watchdog_tripped());  // armed again
}

TEST_CASE("watchdog timeout is settable and 0 turns it off") {
  auto &c = fresh();
  feed(c, wire({sc::kMsgWatchdog, 10, 0}));  // 10 ms: below the minimum
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrConfig);
  g_hal.replies.clear();
  feed(c, wire({sc::kMsgWatchdog, 0, 0}));
  g_hal.now += 100u * F_CPU;
  c.poll();
  CHECK_FALSE(c.watchdog_tripped());
  feed(c, wire({sc::kMsgWatchdog, 50, 0}));  // 50 ms
  c.poll();
  g_hal.now += cmd::ms_to_ticks(51, F_CPU);
  c.poll();
  CHECK(c.watchdog_tripped());
}

TEST_CASE("timestamped entries are queued in order - a chord all or nothing - a full queue refuses") {
  auto &c = fresh();
  feed_at(c, g_hal.now + 100000, 0, 9309091);
  feed_at(c, g_hal.now + 200000, 1, 9309091);
  REQUIRE(g_hal.calls.size() == 2);
  CHECK(g_hal.calls[0].motor == 0);
  CHECK(g_hal.calls[1].motor == 1);
  CHECK(g_hal.calls[1].at_ticks == g_hal.now + 200000);
  for (int i = 2; i < cfg::kQueueSize; ++i) feed_at(c, g_hal.now + 1000000, 3, 9309091);
  CHECK(c.queue_used() == cfg::kQueueSize);
  g_hal.replies.clear();
  g_hal.calls.clear();
  feed_at(c, g_hal.now + 1000000, 3, 9309091);
  CHECK(g_hal.calls.empty());
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][1] == sc::kErrQueueFull);
  feed(c, wire({sc::kMsgStopAll}));
  CHECK(c.queue_used() == 0);
  // A two-entry chord with room for one: neither goes in.
  for (int i = 0; i < cfg::kQueueSize - 1; ++i) feed_at(c, g_hal.now + 1000000, 3, 9309091);
  g_hal.calls.clear();
  std::vector<uint8_t> pl(13);
  pl[0] = sc::kMsgAt;
  sc::put_u32(&pl[1], g_hal.now + 1000000);
  sc::put_entry(&pl[5], 0, 9309091);
  sc::put_entry(&pl[9], 1, 9309091);
  feed(c, wire(pl));
  CHECK(g_hal.calls.empty());
  CHECK(c.queue_used() == cfg::kQueueSize - 1);
}

TEST_CASE("an entry the step ISR took after its time is answered with error late, naming its motor") {
  auto &c = fresh();
  c.poll();
  CHECK(g_hal.replies.empty());
  g_hal.late = 1;  // the ISR made it at once
  g_hal.late_motor = 2;
  c.poll();
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(g_hal.replies[0][0] == sc::kMsgError);
  CHECK(g_hal.replies[0][1] == sc::kErrLate);
  CHECK(g_hal.replies[0][2] == sc::kMsgAt);
  CHECK(g_hal.replies[0][3] == 2);
  CHECK(c.last_error() == sc::kErrLate);
  c.poll();  // once
  CHECK(g_hal.replies.size() == 1);
}

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

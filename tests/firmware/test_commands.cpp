// test_commands.cpp: the firmware's frame handling (host build) against the spec's vectors:
// every host-to-board vector decoded and acted on, the board id, caps and status replies, and
// what is refused (a bad chord entry, wrong lengths), then adversarial byte streams. Built into
// test_firmware; the watchdog and the timed queue: test_commands_timing.cpp; config, driver and
// move commands: test_commands_motors.cpp.
#include <catch2/catch.hpp>

#include <cstddef>
#include <cstring>
#include <random>

#include "command_feed.h"
#include "vectors.h"

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
    } else if (v.kind == "silence") {
      REQUIRE(g_hal.calls.size() == 1);
      CHECK(g_hal.calls[0].kind == FakeHal::kSilence);
      CHECK(g_hal.calls[0].motor == v.num("mask"));
      CHECK(g_hal.replies.empty());
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

TEST_CASE("the caps announced at start-up match the spec's caps vector - a hello's answer has its flag clear") {
  auto &c = fresh();
  c.announce();
  std::vector<uint8_t> announced;
  for (const auto &v : testvec::load())
    if (v.kind == "caps") {
      CHECK(g_hal.sent == v.wire);
      announced = v.payload;
    }
  REQUIRE(g_hal.replies.size() == 1);
  CHECK(sc::caps_announced(g_hal.replies[0].data(), static_cast<uint8_t>(g_hal.replies[0].size())));
  feed(c, wire({sc::kMsgHello}));
  REQUIRE(g_hal.replies.size() == 2);
  std::vector<uint8_t> answer = announced;
  answer[1 + offsetof(sc::CapsBody, flags)] = 0;
  CHECK(g_hal.replies[1] == answer);
  CHECK_FALSE(sc::caps_announced(g_hal.replies[1].data(), static_cast<uint8_t>(g_hal.replies[1].size())));
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

// test_commands_timing.cpp: the firmware's command layer (host build) over time: the watchdog
// that stops every motor when frames stop, and the timestamped queue (order, a chord all or
// nothing, a full queue, an entry taken late). Built into test_firmware.
#include <catch2/catch.hpp>

#include "command_feed.h"

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

TEST_CASE("silence takes a mask of the board's motors - a bit past them or a wrong length is refused") {
  auto &c = fresh();  // four motors
  feed(c, wire({sc::kMsgSilence, 0x0A}));
  REQUIRE(g_hal.calls.size() == 1);
  CHECK(g_hal.calls[0].kind == FakeHal::kSilence);
  CHECK(g_hal.calls[0].motor == 0x0A);
  CHECK(g_hal.replies.empty());
  g_hal.calls.clear();
  const std::vector<std::pair<std::vector<uint8_t>, uint8_t>> refused = {
      {{sc::kMsgSilence, 0x10}, sc::kErrMotor},
      {{sc::kMsgSilence, 0x81}, sc::kErrMotor},
      {{sc::kMsgSilence}, sc::kErrLength},
      {{sc::kMsgSilence, 1, 0}, sc::kErrLength},
  };
  for (const auto &r : refused) {
    g_hal.replies.clear();
    feed(c, wire(r.first));
    CHECK(g_hal.calls.empty());
    REQUIRE(g_hal.replies.size() == 1);
    CHECK(g_hal.replies[0] == std::vector<uint8_t>{sc::kMsgError, r.second, sc::kMsgSilence, 0});
  }
  CHECK(c.frames_bad() == refused.size());
}

// test_console.cpp: what the live console reads and shows, without a terminal: the board's
// status replies published in BoardStats, the engine's record of the latest MIDI events.
#include <catch2/catch.hpp>

#include <cstring>
#include <mutex>
#include <vector>

#include "board/board.h"
#include "live/event_log.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

// A FakeLink whose board answers: every read hands out one status reply (motor m at position
// positions[m], motor 1's switch faulty, `reversals` reversals).
class StatusLink : public FakeLink {
 public:
  StatusLink(std::vector<int32_t> positions, uint16_t reversals) {
    std::vector<uint8_t> payload(1 + sizeof(sc::StatusHead));
    payload[0] = sc::kMsgStatus;
    sc::StatusHead head{};
    head.reversals = reversals;
    head.motor_count = static_cast<uint8_t>(positions.size());
    std::memcpy(&payload[1], &head, sizeof head);
    for (size_t m = 0; m < positions.size(); ++m) {
      sc::StatusMotor s{positions[m], static_cast<uint8_t>(m == 1 ? sc::kMotorEndstopFault : 0)};
      const auto *p = reinterpret_cast<const uint8_t *>(&s);
      payload.insert(payload.end(), p, p + sizeof s);
    }
    reply_ = frame(payload);
  }
  long read(uint8_t *out, size_t len, int) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const size_t n = std::min(len, reply_.size());
    std::memcpy(out, reply_.data(), n);
    return static_cast<long>(n);
  }

 private:
  std::vector<uint8_t> reply_;
};

}  // namespace

TEST_CASE("live: status replies publish each carriage's position, switch faults and the reversals", "[live][console]") {
  StatusLink link({1600, -12, 3200, 0}, 7);
  LiveSession session({LiveBoard{&link, 4, 16000000}}, pool_config({LiveBoard{&link, 4, 16000000}}, Policy::kPoly));
  session.start();
  const BoardStats &st = session.board_stats(0);
  REQUIRE(eventually([&] { return st.last_status_us.load() != 0; }));
  session.stop();
  CHECK(st.position_steps[0].load() == 1600);
  CHECK(st.position_steps[1].load() == -12);
  CHECK(st.position_steps[2].load() == 3200);
  CHECK(st.endstop_fault_mask.load() == 0x02);
  CHECK(st.reversals.load() == 7);
  CHECK(st.reconnects.load() == 0);
  CHECK(session.motor_board(3) == 0);
  CHECK(session.board_motor(3) == 3);
}

TEST_CASE("live: the event log returns the newest events first, with their age", "[live][console]") {
  EventLog log;
  EventLog::Entry out[EventLog::kEvents];
  CHECK(log.latest(out, EventLog::kEvents, 5000000) == 0);
  log.record(note_on(0, 60, 100, 1000000));
  log.record(control_change(2, 1, 64, 1500000));
  REQUIRE(log.latest(out, EventLog::kEvents, 2000000) == 2);
  CHECK(out[0].status == 0xB2);
  CHECK(out[0].data1 == 1);
  CHECK(out[0].data2 == 64);
  CHECK(out[0].age_ms == 500);
  CHECK(out[1].status == 0x90);
  CHECK(out[1].data1 == 60);
  CHECK(out[1].age_ms == 1000);
  // More than the ring holds: the newest kEvents, newest first; max bounds the count.
  for (uint8_t k = 0; k < 40; ++k) log.record(note_on(0, k, 1, 3000000));
  REQUIRE(log.latest(out, EventLog::kEvents, 3000000) == EventLog::kEvents);
  CHECK(out[0].data1 == 39);
  CHECK(out[EventLog::kEvents - 1].data1 == 40 - EventLog::kEvents);
  CHECK(log.latest(out, 3, 3000000) == 3);
  CHECK(log.count() == 42);
}

TEST_CASE("live: the engine records the events it applies", "[live][console]") {
  FakeLink link;
  LiveSession session({LiveBoard{&link, 4, 16000000}}, pool_config({LiveBoard{&link, 4, 16000000}}, Policy::kPoly));
  session.start();
  REQUIRE(session.midi_queue().try_enqueue(note_on(0, 69, 64, monotonic_us())));
  REQUIRE(eventually([&] { return session.recent_events().count() == 1; }));
  session.stop();
  EventLog::Entry e;
  REQUIRE(session.recent_events().latest(&e, 1, monotonic_us()) == 1);
  CHECK(e.status == 0x90);
  CHECK(e.data1 == 69);
  CHECK(e.age_ms < 10000);
}

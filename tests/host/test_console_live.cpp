// test_console_live.cpp: what the live console reads from a running session, without a
// terminal: the board's status replies published in BoardStats, the engine's record of the
// latest MIDI events, and the sampler's model of the whole session. Built into test_live; the
// model's pieces, layout and keys: test_console.cpp; play's model: test_console_play.cpp.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <vector>

#include "board/board.h"
#include "cli/console_model.h"
#include "cli/console_view.h"
#include "live/event_log.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

// A FakeLink whose board answers: every read hands out one status reply (motor m at position
// positions[m] with reversals[m] reversals, motor 1's switch faulty, the board's total their sum).
class StatusLink : public FakeLink {
 public:
  StatusLink(std::vector<int32_t> positions, std::vector<uint16_t> reversals) {
    std::vector<uint8_t> payload(1 + sizeof(sc::StatusHead));
    payload[0] = sc::kMsgStatus;
    sc::StatusHead head{};
    for (uint16_t r : reversals) head.reversals = static_cast<uint16_t>(head.reversals + r);
    head.motor_count = static_cast<uint8_t>(positions.size());
    std::memcpy(&payload[1], &head, sizeof head);
    for (size_t m = 0; m < positions.size(); ++m) {
      sc::StatusMotor s{positions[m], static_cast<uint8_t>(m == 1 ? sc::kMotorEndstopFault : 0), reversals.at(m)};
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
  StatusLink link({1600, -12, 3200, 0}, {5, 0, 2, 65535});
  const std::vector<LiveBoard> pool{LiveBoard{&link, 4, 16000000}};
  const AllocatorConfig config = pool_config(pool, Policy::kPoly);
  LiveSession session(pool, config);
  session.start();
  const BoardStats &st = session.board_stats(0);
  REQUIRE(eventually([&] { return st.last_status_us.load() != 0; }));
  ConsoleSources src;
  src.reconnecting = {false};
  src.music = config;
  const ConsoleModel m = ConsoleSampler().sample(session, src, monotonic_us());
  session.stop();
  CHECK(st.position_steps[0].load() == 1600);
  CHECK(st.position_steps[1].load() == -12);
  CHECK(st.position_steps[2].load() == 3200);
  CHECK(st.endstop_fault_mask.load() == 0x02);
  CHECK(std::vector<uint16_t>{st.motor_reversals[0], st.motor_reversals[1], st.motor_reversals[2],
                              st.motor_reversals[3]} == std::vector<uint16_t>{5, 0, 2, 65535});
  CHECK(st.reversals.load() == 6);  // the board's total, wrapped
  CHECK(st.reconnects.load() == 0);
  CHECK(session.motor_board(3) == 0);
  CHECK(session.board_motor(3) == 3);
  // The console's rows: each motor its own count, the link the board's total.
  REQUIRE(m.motors.size() == 4);
  for (size_t i = 0; i < 4; ++i) {
    INFO("motor " << i);
    CHECK(m.motors[i].has_position);
    CHECK(m.motors[i].reversals == st.motor_reversals[i].load());
  }
  REQUIRE(m.links.size() == 1);
  CHECK(m.links[0].reversals == 6);
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

TEST_CASE("console: the sampler reads a running session", "[live][console]") {
  FakeLink link;
  const std::vector<LiveBoard> pool{LiveBoard{&link, 4, 16000000}};
  const AllocatorConfig config = pool_config(pool, Policy::kPoly);
  LiveSession session(pool, config);
  session.start();
  REQUIRE(session.midi_queue().try_enqueue(note_on(0, 69, 64, monotonic_us())));
  REQUIRE(eventually([&] { return session.motor_note(0) == 69; }));
  REQUIRE(session.perform(StageAction{Action::kMuteMotor, 127, 2}));
  REQUIRE(eventually([&] { return session.stage_mutes() == 0x4; }));
  ConsoleSources src;
  src.board_names = {"fake-port"};
  src.reconnecting = {false};
  src.travel_steps.assign(4, 3200);
  src.music = config;
  src.midi_input = "keys";
  src.setlist_item = 1;
  src.setlist_count = 3;
  src.setlist_name = "encore";
  src.song_motors = 0x8;  // the setlist's song plays motor 3
  ConsoleSampler sampler;
  const ConsoleModel m = sampler.sample(session, src, monotonic_us());
  session.stop();
  REQUIRE(m.motors.size() == 4);
  CHECK(m.motors[0].note == 69);
  CHECK(m.motors[0].hz == Approx(440.0).epsilon(1e-4));
  CHECK(std::fabs(m.motors[0].cents) < 0.1);
  CHECK(m.motors[1].note == -1);
  CHECK(m.motors[2].muted);
  CHECK(m.motors[3].travel_steps == 3200);
  CHECK_FALSE(m.motors[0].has_position);  // the fake board never answers
  REQUIRE(m.links.size() == 1);
  CHECK(m.links[0].name == "fake-port");
  CHECK(m.links[0].health == "no answer");
  REQUIRE_FALSE(m.recent.empty());
  CHECK(m.recent[0].text == "on  ch1 A4 64");
  CHECK(m.events == 1);
  CHECK(m.preset == -1);
  CHECK(m.setlist_item == 1);
  CHECK(m.setlist_count == 3);
  CHECK(m.setlist_name == "encore");
  CHECK(m.motors[3].song);
  CHECK_FALSE(m.motors[2].song);
  const auto lines = console_lines(m, ConsoleFooter{}, 24, 80);
  CHECK(lines[0].text == "stepchoir live  preset -  transpose +0  setlist 2/3 encore");
  CHECK(lines[5].text.find("| song") != std::string::npos);
  CHECK(m.warnings == std::vector<std::string>{"fake-port: the board does not answer"});
}

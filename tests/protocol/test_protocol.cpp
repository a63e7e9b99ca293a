// test_protocol.cpp: the host side of the wire format against the spec's test vectors.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "board/board.h"
#include "core/pitch.h"
#include "stepchoir_protocol.h"
#include "vectors.h"

using namespace stepchoir;

namespace {
// Feeds bytes to a decoder; returns the payloads of good frames and counts bad ones.
std::vector<std::vector<uint8_t>> decode_all(const std::vector<uint8_t> &bytes, int *bad = nullptr) {
  sc::FrameDecoder d;
  std::vector<std::vector<uint8_t>> out;
  for (uint8_t b : bytes) {
    const uint8_t rc = d.push(b);
    if (rc == sc::kFrameOk) out.emplace_back(d.payload(), d.payload() + d.payload_len());
    else if (rc != sc::kFrameNone && bad) ++*bad;
  }
  return out;
}
}  // namespace

TEST_CASE("CRC-16/CCITT-FALSE check value") {
  const char *s = "123456789";
  CHECK(sc::crc16(reinterpret_cast<const uint8_t *>(s), 9) == 0x29B1);
}

TEST_CASE("every spec vector encodes and decodes both ways") {
  const auto vectors = testvec::load();
  REQUIRE(vectors.size() >= 15);
  for (const auto &v : vectors) {
    INFO("PROTOCOL.md:" << v.line << " " << v.kind);
    CHECK(frame(v.payload) == v.wire);
    const auto decoded = decode_all(v.wire);
    REQUIRE(decoded.size() == 1);
    CHECK(decoded[0] == v.payload);
  }
}

TEST_CASE("host encoders produce the spec's payloads") {
  for (const auto &v : testvec::load()) {
    INFO("PROTOCOL.md:" << v.line << " " << v.kind);
    if (v.kind == "set-period") {
      const auto motors = v.nums("motor"), periods = v.nums("period_q8");
      std::vector<sc::PeriodEntry> e;
      for (size_t i = 0; i < motors.size(); ++i) e.push_back({uint8_t(motors[i]), uint32_t(periods[i])});
      CHECK(periods_payload(e) == v.payload);
      for (size_t i = 0; i < e.size(); ++i) {
        sc::PeriodEntry back{};
        REQUIRE(sc::get_entry(&v.payload[i * 4], &back));
        CHECK(back.motor == e[i].motor);
        CHECK(back.period_q8 == e[i].period_q8);
      }
    } else if (v.kind == "config") {
      sc::ConfigBody c{};
      c.motor = uint8_t(v.num("motor"));
      c.driver = uint8_t(v.num("driver"));
      c.microsteps = uint8_t(v.num("microsteps"));
      c.endstop_active_high = uint8_t(v.num("endstop_active_high"));
      c.travel_steps = uint32_t(v.num("travel_steps"));
      c.min_period_q8 = uint32_t(v.num("min_period_q8"));
      c.max_period_q8 = uint32_t(v.num("max_period_q8"));
      c.start_period_q8 = uint32_t(v.num("start_period_q8"));
      c.accel_q8 = uint32_t(v.num("accel_q8"));
      c.pulse_us = uint8_t(v.num("pulse_us"));
      CHECK(config_payload(c) == v.payload);
    } else if (v.kind == "driver") {
      const sc::DriverBody d{uint8_t(v.num("motor")), int8_t(std::stoi(v.str("sleep_pin"))),
                             int8_t(std::stoi(v.str("reset_pin"))), uint8_t(v.num("idle")),
                             uint16_t(v.num("idle_ms")), uint16_t(v.num("wake_us"))};
      CHECK(driver_payload(d) == v.payload);
      sc::DriverBody back{};
      REQUIRE(sc::get_driver(v.payload.data(), uint8_t(v.payload.size()), &back));
      CHECK(back.motor == d.motor);
      CHECK(back.sleep_pin == d.sleep_pin);
      CHECK(back.reset_pin == d.reset_pin);
      CHECK(back.idle == d.idle);
      CHECK(back.idle_ms == d.idle_ms);
      CHECK(back.wake_us == d.wake_us);
      CHECK_FALSE(sc::get_driver(v.payload.data(), uint8_t(v.payload.size() - 1), &back));
      CHECK_FALSE(sc::get_driver(v.payload.data(), uint8_t(v.payload.size() + 1), &back));
    } else if (v.kind == "driver-act") {
      CHECK(driver_act_payload(uint8_t(v.num("motor")), uint8_t(v.num("action"))) == v.payload);
      sc::DriverActBody back{};
      REQUIRE(sc::get_driver_act(v.payload.data(), uint8_t(v.payload.size()), &back));
      CHECK(back.motor == v.num("motor"));
      CHECK(back.action == v.num("action"));
      CHECK_FALSE(sc::get_driver_act(v.payload.data(), 2, &back));
    } else if (v.kind == "caps") {
      const Caps c = parse_caps(v.payload.data(), v.payload.size());
      CHECK(c.protocol_version == v.num("version"));
      CHECK(c.motor_count == v.num("motors"));
      CHECK(c.f_cpu_hz == v.num("f_cpu_hz"));
      CHECK(c.queue_size == v.num("queue"));
      CHECK(c.board_name == v.str("name"));
      CHECK(c.endstops == std::vector<uint8_t>{7, 7, 7, 0});
      CHECK(sc::caps_announced(v.payload.data(), static_cast<uint8_t>(v.payload.size())) == (v.num("announced") == 1));
    } else if (v.kind == "status") {
      const Status s = parse_status(v.payload.data(), v.payload.size());
      CHECK(s.head.frames_ok == v.num("frames_ok"));
      CHECK(s.head.frames_bad == v.num("frames_bad"));
      CHECK(s.head.reversals == v.num("reversals"));
      CHECK(s.head.flags == v.num("flags"));
      const auto positions = v.nums("position"), flags = v.nums("motor_flags"), reversals = v.nums("motor_reversals");
      REQUIRE(s.head.motor_count == positions.size());
      REQUIRE(s.motors.size() == positions.size());
      uint64_t sum = 0;
      for (size_t m = 0; m < s.motors.size(); ++m) {
        CHECK(uint64_t(s.motors[m].position_steps) == positions[m]);
        CHECK(s.motors[m].flags == flags[m]);
        CHECK(s.motors[m].reversals == reversals[m]);
        sum += reversals[m];
      }
      CHECK(s.head.reversals == sum % 65536);  // the board's total is its motors' sum
    } else if (v.kind == "clock") {
      CHECK(v.payload[0] == sc::kMsgClock);
      CHECK(v.payload[1] == v.num("seq"));
      CHECK(sc::get_u32(&v.payload[2]) == v.num("ticks"));
    } else if (v.kind == "set-id" || v.kind == "id") {
      CHECK(v.payload[0] == (v.kind == "id" ? sc::kMsgId : sc::kMsgSetId));
      REQUIRE(v.payload.size() == 1 + sc::kBoardIdBytes);
      CHECK(sc::get_board_id(&v.payload[1]) == v.num("id"));
      std::vector<uint8_t> back(1 + sc::kBoardIdBytes, v.payload[0]);
      sc::put_board_id(&back[1], v.num("id"));
      CHECK(back == v.payload);
    } else if (v.kind == "move") {
      const sc::MoveBody b{uint8_t(v.num("motor")),      uint8_t(v.num("flags")),      uint32_t(v.num("steps")),
                           uint16_t(v.num("speed_min")), uint16_t(v.num("speed_max")), uint32_t(v.num("accel"))};
      CHECK(move_payload(b) == v.payload);
      sc::MoveBody back{};
      REQUIRE(sc::get_move(v.payload.data(), uint8_t(v.payload.size()), &back));
      CHECK(std::memcmp(&back, &b, sizeof b) == 0);
    } else if (v.kind == "move-done") {
      sc::MoveDoneBody d{};
      REQUIRE(sc::get_move_done(v.payload.data(), uint8_t(v.payload.size()), &d));
      CHECK(d.motor == v.num("motor"));
      CHECK(d.end == v.num("end"));
      CHECK(d.position == std::stol(v.str("position")));
      CHECK(d.steps == v.num("steps"));
      std::vector<uint8_t> back(1 + sizeof d);
      CHECK(sc::put_move_done(back.data(), d) == back.size());
      CHECK(back == v.payload);
    } else if (v.kind == "set-position") {
      CHECK(set_position_payload(uint8_t(v.num("motor")), int32_t(std::stol(v.str("position")))) == v.payload);
    } else if (v.kind == "silence") {
      std::vector<uint8_t> motors;
      for (uint8_t m = 0; m < sc::kMaxMotors; ++m)
        if (v.num("mask") & (1u << m)) motors.push_back(m);
      CHECK(silence_payload(motors) == v.payload);
    } else if (v.kind == "at") {
      CHECK(sc::get_u32(&v.payload[1]) == v.num("ticks"));
      sc::PeriodEntry e{};
      REQUIRE(sc::get_entry(&v.payload[5], &e));
      CHECK(e.motor == v.num("motor"));
      CHECK(e.period_q8 == v.num("period_q8"));
    }
  }
}

TEST_CASE("one motor costs 8 bytes on the wire - each extra chord motor 4") {
  for (uint8_t n = 1; n <= 5; ++n) {
    std::vector<sc::PeriodEntry> e;
    for (uint8_t m = 0; m < n; ++m) e.push_back({m, hz_to_period_q8(30.0 + 1000.0 * m, 16000000)});
    CHECK(frame(periods_payload(e)).size() == 8u + 4u * (n - 1));
  }
}

TEST_CASE("pitch resolution is better than 0.01 cent from 30 Hz to 4186 Hz") {
  for (double hz : {30.0, 32.70, 440.0, 1000.0, 4186.0, 8000.0}) {
    const uint32_t p = hz_to_period_q8(hz, 16000000);
    INFO(hz << " Hz");
    CHECK(std::abs(cents(period_q8_to_hz(p, 16000000), hz)) < 0.01);
    CHECK(std::abs(cents(period_q8_to_hz(p + 1, 16000000), period_q8_to_hz(p, 16000000))) < 0.01);
  }
  CHECK(hz_to_period_q8(15.0, 16000000) == 0);  // below the 28-bit field
  CHECK(hz_to_period_q8(0, 16000000) == 0);
}

TEST_CASE("decoder resyncs after any garbage within one frame") {
  std::mt19937 rng(1234);
  const auto good = frame(periods_payload({{1, hz_to_period_q8(440, 16000000)}}));
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<uint8_t> bytes;
    const int n = int(rng() % 200);
    for (int i = 0; i < n; ++i) bytes.push_back(uint8_t(rng()));
    // garbage, then two good frames: at most the first may be lost
    bytes.insert(bytes.end(), good.begin(), good.end());
    bytes.insert(bytes.end(), good.begin(), good.end());
    const auto frames = decode_all(bytes);
    int matches = 0;
    for (const auto &f : frames) matches += (frame(f) == good);
    INFO("trial " << trial);
    CHECK(matches >= 1);
  }
}

TEST_CASE("single corrupted bytes never produce a good frame") {
  const auto good = frame(periods_payload({{2, hz_to_period_q8(261.63, 16000000)}, {3, 0}}));
  for (size_t i = 0; i + 1 < good.size(); ++i) {
    for (int v = 0; v < 256; ++v) {
      if (v == good[i]) continue;
      auto bad = good;
      bad[i] = uint8_t(v);
      for (const auto &f : decode_all(bad)) CHECK(f != periods_payload({{2, hz_to_period_q8(261.63, 16000000)}, {3, 0}}));
      int nbad = 0;
      CHECK(decode_all(bad, &nbad).empty());
    }
  }
}

TEST_CASE("caps of a protocol version 2 board: no flags byte, its name whole, never announced") {
  std::vector<uint8_t> v2 = {sc::kMsgCaps, 2, 4, 0x00, 0x24, 0xf4, 0x00, 0x18, 7, 7, 7, 0, 0};
  for (char c : std::string("uno_cnc_shield_v3")) v2.push_back(static_cast<uint8_t>(c));
  const Caps c = parse_caps(v2.data(), v2.size());
  CHECK(c.protocol_version == 2);
  CHECK(c.board_name == "uno_cnc_shield_v3");
  CHECK_FALSE(sc::caps_announced(v2.data(), static_cast<uint8_t>(v2.size())));  // 'u', the name's first byte, is odd
}

TEST_CASE("reply parsers reject short or inconsistent payloads with a message") {
  const uint8_t caps[3] = {sc::kMsgCaps, 1, 4};
  CHECK_THROWS_WITH(parse_caps(caps, sizeof caps), Catch::Contains("caps reply"));
  std::vector<uint8_t> st(1 + sizeof(sc::StatusHead), 0);
  st[0] = sc::kMsgStatus;
  st[1 + offsetof(sc::StatusHead, motor_count)] = 2;  // claims 2 motors, carries none
  CHECK_THROWS_WITH(parse_status(st.data(), st.size()), Catch::Contains("expected"));
}

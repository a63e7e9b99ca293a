// test_moves.cpp: a move's steps on the motor (motor.h account_move) and its speed profile
// (move_ramp.h), built for the host with plain bytes for the DIR port and the switches.
// Expected values are worked out here from v^2 = v0^2 + 2as, not read off the code.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <random>

// motor.h's functions have internal linkage (sched::now() is test_motor.cpp's): this file uses
// a few of them.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "motor.h"
#pragma GCC diagnostic pop
#include "move_ramp.h"

using namespace sched;

namespace {

const uint8_t kDirBit = 0x10, kMaxBit = 0x04, kMinBit = 0x08;

// One motor in a move, switches active low on two bits of one port (released), at position 0.
struct MoveRig {
  uint8_t dir = 0, port = 0xFF;
  Motor m{};
  MoveRig(bool up, uint32_t steps, uint8_t move_flags) {
    m.dir_port = &dir;
    m.dir_mask = kDirBit;
    m.sw_up_pin = m.sw_down_pin = &port;
    m.sw_up_mask = kMaxBit;
    m.sw_down_mask = kMinBit;
    m.flags = (uint8_t)(kArmed | kLimits | kMove | (up ? kUp : 0));
    if (up) dir |= kDirBit;
    m.limit_hi = 10;  // soft limits a move ignores
    m.limit_lo = -10;
    m.period_q8 = 256u * 1000;
    m.move_left = steps;
    m.move_flags = move_flags;
  }
  void press(uint8_t bit) { port = (uint8_t)(port & ~bit); }
  // Steps until the move ends (at most n); returns the steps taken.
  uint32_t run(uint32_t n) {
    uint32_t k = 0;
    while (k < n && (m.flags & kMove)) account_step(m), ++k;
    return k;
  }
};

}  // namespace

TEST_CASE("move: takes exactly its steps past the soft limits, then falls silent", "[motor]") {
  for (bool up : {true, false}) {
    MoveRig r(up, 50, 0);
    r.m.cmd = kCmdLive;  // a speed change the main loop posted for the step after the last
    CHECK(r.run(1000) == 50u);
    CHECK(r.m.position == (up ? 50 : -50));
    CHECK(r.m.period_q8 == 0u);
    CHECK(r.m.move_end == sc::kMoveEndSteps);
    CHECK(r.m.cmd == kCmdNone);  // dropped: it must not start the motor again
    CHECK(bool(r.m.flags & kUp) == up);  // no reversal
    CHECK(bool(r.dir & kDirBit) == up);
    CHECK(r.m.reversals == 0);
  }
}

TEST_CASE("move: toward a switch it ends at the first step that finds it pressed", "[motor]") {
  for (bool up : {true, false}) {
    MoveRig r(up, 1000, sc::kMoveToSwitch);
    CHECK(r.run(30) == 30u);
    r.press(up ? kMaxBit : kMinBit);
    CHECK(r.run(1000) == 1u);
    CHECK(r.m.move_end == sc::kMoveEndSwitch);
    CHECK(r.m.position == (up ? 31 : -31));
    CHECK(r.m.move_left == 1000u - 31u);
    CHECK(bool(r.m.flags & kUp) == up);
  }
}

TEST_CASE("move: the switch behind, or any switch without kMoveToSwitch, does not stop it", "[motor]") {
  MoveRig away(true, 20, sc::kMoveToSwitch);
  away.press(kMinBit);  // backing off the min switch
  CHECK(away.run(1000) == 20u);
  CHECK(away.m.move_end == sc::kMoveEndSteps);
  MoveRig off(true, 20, 0);
  off.press(kMaxBit);  // one input for both ends reads pressed while the carriage leaves it
  CHECK(off.run(1000) == 20u);
  CHECK(off.m.move_end == sc::kMoveEndSteps);
}

TEST_CASE("move ramp: isqrt is the floor of the square root", "[motor]") {
  std::mt19937 rng(7);
  for (uint32_t x : {0u, 1u, 2u, 3u, 4u, 15u, 16u, 24999999u, 25000000u, 0xFFFFFFFFu}) {
    INFO(x);
    CHECK(ramp::isqrt(x) == uint32_t(std::floor(std::sqrt(double(x)))));
  }
  for (int i = 0; i < 10000; ++i) {
    const uint32_t x = rng();
    const uint32_t s = ramp::isqrt(x);
    CHECK((uint64_t(s) * s <= x && uint64_t(s + 1) * (s + 1) > x));
  }
}

TEST_CASE("move ramp: v^2 = v0^2 + 2an up, speed_max between, the same down to v0", "[motor]") {
  const uint16_t v0 = 400, vmax = 3200;
  const uint32_t a = 16000, steps = 4000;
  const ramp::Ramp r = ramp::make(v0, vmax, a);
  for (uint32_t done = 1; done < steps; ++done) {
    const uint32_t left = steps - done;
    const double n = double(std::min(done, left) - 1);
    const double want = std::min<double>(vmax, std::sqrt(double(v0) * v0 + 2.0 * a * n));
    INFO("done " << done);
    const uint16_t v = ramp::speed(r, done, left);
    CHECK(v <= want);
    CHECK(v > want - 1.0);  // rounded down
  }
  CHECK(ramp::speed(r, 1, steps - 1) == v0);  // the first interval
  CHECK(ramp::speed(r, steps - 1, 1) == v0);  // the last one
  CHECK(ramp::speed(r, steps / 2, steps / 2) == vmax);
  // A short move turns back before speed_max: a triangle, its peak sqrt(v0^2 + 2a(n-1)).
  const uint32_t short_steps = 200;
  uint16_t peak = 0;
  for (uint32_t done = 1; done < short_steps; ++done) peak = std::max(peak, ramp::speed(r, done, short_steps - done));
  CHECK(peak == uint16_t(std::sqrt(double(v0) * v0 + 2.0 * a * 99)));
  // One speed: no ramp.
  const ramp::Ramp flat = ramp::make(800, 800, a);
  CHECK(ramp::speed(flat, 1, 99) == 800);
  CHECK(ramp::speed(flat, 50, 50) == 800);
}

TEST_CASE("move ramp: periods from speeds, within the firmware's period limits", "[motor]") {
  CHECK(ramp::period_q8(sc::kMoveSpeedMax, 16000000) == sc::kPeriodQ8Min);
  CHECK(ramp::period_q8(sc::kMoveSpeedMin, 16000000) <= sc::kPeriodQ8Max);
  CHECK(ramp::period_q8(1000, 16000000) == 16000u * 256u);
  // The fastest ramp: no overflow on the way to speed_max.
  const ramp::Ramp r = ramp::make(sc::kMoveSpeedMin, sc::kMoveSpeedMax, sc::kMoveAccelMax);
  for (uint32_t done = 1; done < 100; ++done) CHECK(ramp::speed(r, done, 1000) <= sc::kMoveSpeedMax);
  CHECK(ramp::speed(r, 2, 1000) == uint16_t(std::sqrt(256.0 + 2e6)));
}

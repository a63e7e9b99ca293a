// usb_bridge_tests.cpp: the USB-serial bridge models, byte by byte against their rules.
#include <catch2/catch.hpp>

#include <algorithm>
#include <vector>

#include "pacer.h"
#include "usb_bridge.h"

using namespace vboard;

namespace {

const uint64_t kMs = 1000000;

// When a write of n bytes lands in a USB bridge's OUT endpoint, after its frame's start.
uint64_t bus(size_t n) {
  const BridgeTiming t = link_model_timing(LinkModel::k16u2);
  return t.bus_ns + t.bus_byte_ns * n;
}

UsbBridge make(LinkModel m, uint64_t frame_phase = 0, uint64_t flush_phase = 0, unsigned ftdi_ms = 16) {
  return UsbBridge(m, link_model_timing(m, ftdi_ms), frame_phase, flush_phase);
}

// The 16u2 model with each release on one place in its period (no wander): for the tests of
// exact times.
UsbBridge make_16u2_steady(uint64_t frame_phase, uint64_t flush_phase) {
  BridgeTiming t = link_model_timing(LinkModel::k16u2);
  t.release_wander_ns = 0;
  return UsbBridge(LinkModel::k16u2, t, frame_phase, flush_phase);
}

// Host time (ns) at which the board's byte sent at sent_ns reaches the host, stepping the host
// clock by 20 us as the virtual board's loop does (sent_ns: not before the last call's answer).
uint64_t arrival(UsbBridge &b, uint64_t sent_ns) {
  b.from_board(0x55, sent_ns);
  std::vector<uint8_t> out;
  for (uint64_t t = sent_ns;; t += 20000) {
    b.to_host(t, out);
    if (!out.empty()) return t;
    if (t > sent_ns + 100 * kMs) return UINT64_MAX;
  }
}

}  // namespace

TEST_CASE("usb bridge: link model names") {
  LinkModel m;
  for (const char *name : {"ideal", "16u2", "ftdi", "ch340"}) {
    REQUIRE(parse_link_model(name, m));
    CHECK(std::string(link_model_name(m)) == name);
  }
  CHECK_FALSE(parse_link_model("cp2102", m));
}

TEST_CASE("usb bridge: ideal passes bytes at once both ways") {
  UsbBridge b = make(LinkModel::kIdeal);
  const uint8_t bytes[3] = {1, 2, 3};
  b.from_host(bytes, 3, 5000);
  REQUIRE(b.board_byte_ready(5000));
  CHECK(b.board_byte_pop() == 1);
  CHECK(arrival(b, 7000) == 7000);
}

TEST_CASE("usb bridge: a host write reaches the board in the next 1 ms frame, when the 16U2's loop comes round") {
  const BridgeTiming t = link_model_timing(LinkModel::k16u2);
  REQUIRE(t.first_byte_min_ns > 7000);  // 121 and 270 cycles of 16 MHz: bench/results/usb-16u2-firmware.md
  REQUIRE(t.first_byte_max_ns < 17000);
  CHECK(bus(8) == 15336);  // a note frame's transaction: 120 bit times, then 8 a byte, at 12 Mbit/s
  UsbBridge b = make(LinkModel::k16u2, 300000);
  const uint8_t byte = 0x42;
  b.from_host(&byte, 1, 2 * kMs + 100000);  // written 0.1 ms into a frame that began at 1.3 ms
  CHECK_FALSE(b.board_byte_ready(2 * kMs + 300000 + bus(1) + t.first_byte_min_ns - 1));
  CHECK(b.board_byte_ready(2 * kMs + 300000 + bus(1) + t.first_byte_max_ns));
  b.board_byte_pop();
  b.from_host(&byte, 1, 2 * kMs + 300000);  // written on a frame's first ns: the next one
  CHECK_FALSE(b.board_byte_ready(3 * kMs + 300000 + bus(1) + t.first_byte_min_ns - 1));
  CHECK(b.board_byte_ready(3 * kMs + 300000 + bus(1) + t.first_byte_max_ns));
  // The ideal link's writes wait for no frame; an FTDI or CH340 bridge's for one and its
  // transaction only, longer for a longer packet (64 bytes at most).
  UsbBridge ftdi = make(LinkModel::kFtdi, 300000);
  ftdi.from_host(&byte, 1, 2 * kMs + 100000);
  CHECK_FALSE(ftdi.board_byte_ready(2 * kMs + 300000 + bus(1) - 1));
  CHECK(ftdi.board_byte_ready(2 * kMs + 300000 + bus(1)));
  ftdi.board_byte_pop();
  const std::vector<uint8_t> many(100, 0x42);
  ftdi.from_host(many.data(), many.size(), 3 * kMs + 100000);
  CHECK(ftdi.next_board_byte_ns() == 3 * kMs + 300000 + bus(64));
}

TEST_CASE("usb bridge: the 16U2's first byte falls anywhere in its range, and host bytes keep their order") {
  const BridgeTiming t = link_model_timing(LinkModel::k16u2);
  UsbBridge b = make(LinkModel::k16u2);
  uint64_t earliest = UINT64_MAX, latest = 0;
  for (uint64_t frame = 1; frame <= 400; ++frame) {
    const uint8_t byte = uint8_t(frame);
    b.from_host(&byte, 1, frame * kMs - 500000);
    const uint64_t wait = b.next_board_byte_ns() - frame * kMs - bus(1);
    earliest = std::min(earliest, wait);
    latest = std::max(latest, wait);
    b.board_byte_pop();
  }
  CHECK(earliest >= t.first_byte_min_ns);
  CHECK(latest <= t.first_byte_max_ns);
  CHECK(latest - earliest > (t.first_byte_max_ns - t.first_byte_min_ns) * 9 / 10);
  // Two writes in one frame: the second's bytes never reach the board before the first's.
  for (uint64_t frame = 500; frame < 600; ++frame) {
    const uint8_t first = 1, second = 2;
    b.from_host(&first, 1, frame * kMs + 100000);
    b.from_host(&second, 1, frame * kMs + 200000);
    const uint64_t first_at = b.next_board_byte_ns();
    REQUIRE(b.board_byte_pop() == 1);
    CHECK(b.next_board_byte_ns() >= first_at);
    REQUIRE(b.board_byte_pop() == 2);
  }
}

TEST_CASE("usb bridge: each model says when it next passes board bytes to the host") {
  UsbBridge ideal = make(LinkModel::kIdeal);
  CHECK(ideal.next_host_pass_ns() == UINT64_MAX);
  ideal.from_board(0x11, 7000);
  CHECK(ideal.next_host_pass_ns() == 0);  // passed already: the loop writes it at once
  std::vector<uint8_t> out;
  ideal.to_host(7000, out);
  CHECK(ideal.next_host_pass_ns() == UINT64_MAX);
  out.clear();
  UsbBridge u = make_16u2_steady(0, 1000000);
  CHECK(u.next_host_pass_ns() == UINT64_MAX);
  u.from_board(0x22, 1200000);
  CHECK(u.next_host_pass_ns() == 5156500);  // the next Timer0 overflow, and 968 cycles' copy
  u.to_host(3000000, out);                  // a look in between passes nothing
  CHECK(u.next_host_pass_ns() == 5156500);
  u.to_host(5096000, out);  // the overflow: on its way
  CHECK(out.empty());
  CHECK(u.next_host_pass_ns() == 5156500);
  u.to_host(5156500, out);
  CHECK(out.size() == 1);
  CHECK(u.next_host_pass_ns() == UINT64_MAX);
  for (int i = 0; i < 97; ++i) u.from_board(uint8_t(i), 6000000);  // more than 96 wait
  CHECK(u.next_host_pass_ns() == 6432875);
}

TEST_CASE("usb bridge: 16u2 holds board bytes until its 4.096 ms timer overflows") {
  UsbBridge b = make_16u2_steady(0, 1000000);
  // Overflows at 1.0, 5.096, 9.192 ms ...: a byte sent at 1.2 ms waits for 5.096 ms, then
  // the 16U2's copy into its endpoint (60.5 us).
  const uint64_t t = arrival(b, 1200000);
  CHECK(t >= 5156500);
  CHECK(t < 5156500 + 20000);
  // Over many bytes the wait spreads over the whole period, never longer.
  uint64_t longest = 0, shortest = UINT64_MAX;
  uint64_t sent = 10 * kMs;
  for (int i = 1; i < 60; ++i) {  // host time only moves on: each byte some way after the last
    const uint64_t got = arrival(b, sent);
    const uint64_t wait = got - sent;
    sent = got + uint64_t(i) * 617000 % 4096000;
    longest = std::max(longest, wait);
    shortest = std::min(shortest, wait);
  }
  CHECK(longest <= 4156500 + 20000);
  CHECK(longest > 3860000);
  CHECK(shortest < 360000);
  CHECK(shortest >= 60500);  // never sooner than the copy
}

TEST_CASE("usb bridge: 16u2 releases wander over the loop's span, each period's the same whenever asked") {
  const BridgeTiming t = link_model_timing(LinkModel::k16u2);
  REQUIRE(t.release_wander_ns == 56125);  // 898 cycles of 16 MHz: bench/results/usb-16u2-firmware.md
  const uint64_t period = t.flush_period_ns, phase = 700000;
  UsbBridge b = make(LinkModel::k16u2, 0, phase);
  UsbBridge twin = make(LinkModel::k16u2, 0, phase);
  uint64_t earliest = UINT64_MAX, latest = 0;
  std::vector<uint8_t> out;
  for (uint64_t k = 1; k <= 300; ++k) {
    const uint64_t expiry = phase + k * period;
    // A byte just before the overflow goes in its release, whenever that comes; it is said
    // ahead, and nothing goes before.
    b.from_board(uint8_t(k), expiry - 1000);
    const uint64_t said = b.next_host_pass_ns();
    CHECK(said >= expiry + t.release_delay_ns);
    CHECK(said <= expiry + t.release_delay_ns + t.release_wander_ns);
    out.clear();
    b.to_host(said - 1, out);
    CHECK(out.empty());
    b.to_host(said, out);
    REQUIRE(out.size() == 1);
    CHECK(out[0] == uint8_t(k));
    earliest = std::min(earliest, said - expiry - t.release_delay_ns);
    latest = std::max(latest, said - expiry - t.release_delay_ns);
    // The same period's wander, asked of a bridge whose bytes came otherwise: only every
    // second period, each asked only after the expiry.
    if (k % 2) continue;
    twin.from_board(0, expiry + 1);  // after the overflow, before the loop saw it: or not
    const uint64_t twin_said = twin.next_host_pass_ns();
    out.clear();
    twin.to_host(twin_said, out);
    REQUIRE(out.size() == 1);
    CHECK(((twin_said == said) || (twin_said >= said + period - t.release_wander_ns)));
  }
  CHECK(earliest < t.release_wander_ns / 10);
  CHECK(latest > t.release_wander_ns * 9 / 10);
}

TEST_CASE("usb bridge: 16u2 sends 433 us after more than 96 bytes wait, and bytes keep their order") {
  UsbBridge b = make_16u2_steady(0, 0);
  std::vector<uint8_t> out;
  for (int i = 0; i < 96; ++i) b.from_board(uint8_t(i), 100000 + uint64_t(i) * 10000);
  b.to_host(1100000, out);
  CHECK(out.empty());  // 96 wait for the overflow at 4.096 ms
  b.from_board(96, 1100000);
  b.to_host(1100000 + 432874, out);
  CHECK(out.empty());  // the 16U2 copies them into its endpoint first
  b.from_board(97, 1200000);  // came after: the overflow's
  b.to_host(1100000 + 432875, out);
  REQUIRE(out.size() == 97);
  for (int i = 0; i < 97; ++i) CHECK(out[size_t(i)] == uint8_t(i));
  CHECK(b.board_bytes_waiting() == 1);
  b.to_host(4096000 + 60499, out);
  CHECK(out.size() == 97);
  b.to_host(4096000 + 60500, out);
  CHECK(out.size() == 98);
  CHECK(b.board_bytes_waiting() == 0);
  // An overflow while a burst is on its way: its bytes follow the burst's, never before.
  for (int i = 0; i < 97; ++i) b.from_board(uint8_t(i), 8192000 - 1000);
  b.from_board(200, 8192000 - 500);
  out.clear();
  b.to_host(8192000 + 60500, out);
  CHECK(out.empty());
  b.to_host(8192000 - 1000 + 432875, out);
  REQUIRE(out.size() == 98);
  CHECK(out.back() == 200);
}

TEST_CASE("usb bridge: ftdi waits for its latency timer or a full 62-byte packet") {
  UsbBridge b = make(LinkModel::kFtdi, 0, 16 * kMs);
  CHECK(arrival(b, 1 * kMs) == 16 * kMs);  // the timer expires at 16 ms
  // A full packet goes at once and restarts the timer.
  std::vector<uint8_t> out;
  for (int i = 0; i < 62; ++i) b.from_board(uint8_t(i), 20 * kMs);
  b.to_host(20 * kMs, out);
  CHECK(out.size() == 62);
  out.clear();
  b.from_board(1, 21 * kMs);
  b.to_host(35 * kMs, out);
  CHECK(out.empty());  // 20 + 16 = 36 ms, not the old period's 32 ms
  b.to_host(36 * kMs, out);
  CHECK(out.size() == 1);
  // With the latency timer at 1 ms (the low-latency flag) a byte waits at most 1 ms.
  UsbBridge fast = make(LinkModel::kFtdi, 0, 0, 1);
  CHECK(arrival(fast, 1500000) - 1500000 <= 500000);
}

TEST_CASE("usb bridge: ch340 sends in the next 1 ms frame, or a full 32-byte packet at once") {
  UsbBridge b = make(LinkModel::kCh340, 0, 0);
  CHECK(arrival(b, 2400000) == 3 * kMs);
  std::vector<uint8_t> out;
  for (int i = 0; i < 32; ++i) b.from_board(uint8_t(i), 5100000);
  b.to_host(5100000, out);
  CHECK(out.size() == 32);
}

TEST_CASE("usb bridge: host bytes are stamped with their wall arrival, before or after the simulation's now") {
  Pacer pacer(16e6, 0, 50 * kMs);
  pacer.start(0, 0);  // simulated ns equal wall ns
  // Bytes read at wall 2.25 ms arrived at 2.25 ms, wherever the simulation stands.
  CHECK(host_arrival_ns(pacer, 2250000) == 2250000);

  // An FTDI bridge (a frame's bytes once its transaction ends) with frames starting at 0.3 ms:
  // the byte written at 2.25 ms goes in the 2.3 ms frame, as on a real board, while the
  // simulation (at 2.29 ms) has not reached that frame.
  UsbBridge b = make(LinkModel::kFtdi, 300000);
  const uint8_t byte = 0x42;
  b.from_host(&byte, 1, host_arrival_ns(pacer, 2250000));
  CHECK(b.next_board_byte_ns() == 2300000 + bus(1));
  CHECK_FALSE(b.board_byte_ready(2300000 + bus(1) - 1));
  CHECK(b.board_byte_ready(2300000 + bus(1)));
  b.board_byte_pop();
  CHECK(b.next_board_byte_ns() == UINT64_MAX);
  // The simulation at 2.45 ms: the frame's start lies inside its lead, so the board takes the
  // byte at once, 0.15 ms late; stamped with the simulation's now it would wait for 3.3 ms.
  b.from_host(&byte, 1, host_arrival_ns(pacer, 2250000));
  CHECK(b.board_byte_ready(2450000));
  b.board_byte_pop();
  // The simulation behind, at 2.1 ms: read at wall 2.6 ms, the byte goes in the 3.3 ms frame;
  // stamped with the simulation's now it would go in the 2.3 ms one, before it was written.
  b.from_host(&byte, 1, host_arrival_ns(pacer, 2600000));
  CHECK_FALSE(b.board_byte_ready(3300000 + bus(1) - 1));
  CHECK(b.board_byte_ready(3300000 + bus(1)));
  b.board_byte_pop();
  // The ideal link holds a byte that arrived after the simulation's now until then.
  UsbBridge ideal = make(LinkModel::kIdeal, 0);
  ideal.from_host(&byte, 1, host_arrival_ns(pacer, 2600000));
  CHECK_FALSE(ideal.board_byte_ready(2100000));
  CHECK(ideal.board_byte_ready(2600000));
}

// test_usb_bridge.cpp: the virtual board's USB bridge models (--link-model) on the real
// firmware: when host frames reach the UART and when replies reach the host, from the trace's
// cycles (exact), against the ideal link; the reset on open and the bootloaders' hold.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

struct BridgeRun {
  std::vector<double> frame_ns;   // host time of each host frame's delimiter at the UART
  std::vector<double> frame_us;   // each host frame's first byte -> its delimiter at the UART
  std::vector<double> reply_ns;   // host time of each pass of board bytes to the host
  // Host time at which frame i's reply was whole at the host: the last pass before the next
  // frame (the host sends it only then; a reply may go in pieces: byte by byte on the ideal
  // link, or split by a 16U2 timer overflow).
  double reply_done_ns(size_t i) const {
    const double next = i + 1 < frame_ns.size() ? frame_ns[i + 1] : 1e300;
    double done = -1;
    for (double t : reply_ns)
      if (t > frame_ns[i] && t < next) done = t;
    return done;
  }
};

// Sends `rounds` clock requests one at a time (each after the last one's reply, then a wall
// pause of 0-2 ms so that they fall at every phase of the USB frames) through `model`.
BridgeRun clock_rounds(const std::string &model, int rounds) {
  const std::string trace_path = e2e::scratch("bridge-" + model + ".csv");
  VboardProcess vb({"--board", "uno", "--no-pacing", "--seconds", "60", "--trace", trace_path,
                           "--trace-frames", "--link-model", model, "--quiet"});
  Board b(open_link(vb.pty()));
  b.hello();
  for (int i = 0; i < rounds; ++i) {
    e2e::board_ticks(b, uint8_t(i));
    std::this_thread::sleep_for(std::chrono::microseconds((i * 737) % 2000));
  }
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  BridgeRun run;
  // The clock requests' delimiters are the last rows (before them: hello's, and its resync
  // delimiter unless the firmware's receiver was not on yet).
  REQUIRE(t.frame_ends.size() >= size_t(rounds));
  for (size_t i = t.frame_ends.size() - size_t(rounds); i < t.frame_ends.size(); ++i) {
    run.frame_ns.push_back(double(t.frame_ends[i]) * 1e9 / t.f_cpu_hz);
    run.frame_us.push_back(double(t.frame_ends[i] - t.frame_starts[i]) * 1e6 / t.f_cpu_hz);
  }
  for (const auto &r : t.replies) {
    run.reply_ns.push_back(double(r.cycle) * 1e9 / t.f_cpu_hz);
  }
  return run;
}

// How far apart times fall within a period (ns): the width of the smallest arc of the circle
// of circumference `period` that holds every t mod period.
double phase_spread(const std::vector<double> &times, double period) {
  std::vector<double> r;
  for (double t : times) r.push_back(std::fmod(t, period));
  std::sort(r.begin(), r.end());
  double widest_gap = r.front() + period - r.back();
  for (size_t i = 1; i < r.size(); ++i) widest_gap = std::max(widest_gap, r[i] - r[i - 1]);
  return period - widest_gap;
}

}  // namespace

TEST_CASE("link: on the 16u2 model host frames land on 1 ms USB frames and replies on 4.096 ms") {
  const int kRounds = 60;
  const BridgeRun usb = clock_rounds("16u2", kRounds);
  const BridgeRun ideal = clock_rounds("ideal", kRounds);
  for (const BridgeRun *run : {&usb, &ideal}) {
    for (size_t i = 0; i < run->frame_ns.size(); ++i) REQUIRE(run->reply_done_ns(i) > 0);
  }
  // Host -> board: every clock request (the same length) reaches the UART at one place of a 1 ms
  // frame, give or take where the 16U2's main loop stands when the packet lands (its first byte
  // 7.6-16.9 us into the frame: bench/results/usb-16u2-firmware.md); on the ideal link, anywhere.
  const double usb_in = phase_spread(usb.frame_ns, 1e6), ideal_in = phase_spread(ideal.frame_ns, 1e6);
  // Board -> host: the 16U2 passes replies at its Timer0 overflows only (hello's too), each
  // up to 898 cycles (56.1 us) after its overflow as its loop comes round.
  const double usb_out = phase_spread(usb.reply_ns, 4096000), ideal_out = phase_spread(ideal.reply_ns, 4096000);
  // Round trips in board time: up to a frame in, the firmware, up to an overflow out.
  double usb_rtt_max = 0, ideal_rtt_max = 0, usb_rtt_sum = 0;
  for (size_t i = 0; i < usb.frame_ns.size(); ++i) {
    usb_rtt_max = std::max(usb_rtt_max, usb.reply_done_ns(i) - usb.frame_ns[i]);
    usb_rtt_sum += usb.reply_done_ns(i) - usb.frame_ns[i];
    ideal_rtt_max = std::max(ideal_rtt_max, ideal.reply_done_ns(i) - ideal.frame_ns[i]);
  }
  INFO("phase spread in: 16u2 " << usb_in / 1e3 << " us, ideal " << ideal_in / 1e3 << " us; out: 16u2 "
                                << usb_out / 1e3 << " us, ideal " << ideal_out / 1e3 << " us; reply after the frame: 16u2 max "
                                << usb_rtt_max / 1e3 << " us mean " << usb_rtt_sum / usb.frame_ns.size() / 1e3
                                << " us, ideal max " << ideal_rtt_max / 1e3 << " us");
  CHECK(usb_in < 11e3);
  CHECK(usb_in > 5e3);
  CHECK(ideal_in > 300e3);
  CHECK(usb_out < 56.2e3);
  CHECK(usb_out > 20e3);
  CHECK(ideal_out > 1000e3);
  CHECK(usb_rtt_max < 4096e3 + 300e3);
  CHECK(usb_rtt_max > 3000e3);  // some replies just missed an overflow
  CHECK(ideal_rtt_max < 300e3);
  // A clock request is 6 bytes on the wire. The ideal link hands them to the UART a byte time
  // (10 us) apart; the 16U2 one a pass of its main loop (about 15 us, docs/usb-bridges.md).
  const auto [usb_min, usb_max] = std::minmax_element(usb.frame_us.begin(), usb.frame_us.end());
  const auto [ideal_min, ideal_max] = std::minmax_element(ideal.frame_us.begin(), ideal.frame_us.end());
  INFO("a clock request's first byte -> delimiter: 16u2 " << *usb_min << "-" << *usb_max << " us, ideal " << *ideal_min
                                                           << "-" << *ideal_max << " us");
  CHECK(*ideal_min > 49.9);
  CHECK(*ideal_max < 51.0);
  CHECK(*usb_min > 5 * 15.0);
  CHECK(*usb_max < 5 * 16.0);
}

TEST_CASE("link: opening the port resets an Uno or a Mega, and the host waits out the bootloader") {
  for (const std::string board : {"uno", "mega"}) {
    INFO(board);
    const std::string trace_path = e2e::scratch("reset-" + board + ".csv");
    {
      VboardProcess vb({"--board", board, "--auto-reset", "--link-model", "16u2", "--no-pacing", "--seconds", "30",
                        "--trace", trace_path, "--trace-frames", "--quiet"});
      // The test's own open resets the board; greet sends nothing until the firmware's
      // capabilities come, then a tone plays.
      Board b(open_link(vb.pty()));
      const Caps caps = b.greet();
      CHECK(caps.motor_count >= 4);
      e2e::board_ticks(b, 7);
      REQUIRE(vb.stop() == 0);
    }
    const tr::Trace t = tr::read_trace(trace_path);
    REQUIRE(t.mcu_resets.size() == 1);
    // Nothing the host sent reached the UART before the firmware said it was there: the first
    // frame is the clock request, after the capabilities (the first pass of bytes to the host
    // 100 ms or more after the reset: a pass sooner is the power-on announcement, which the
    // bridge held until its next timer overflow).
    const uint64_t reset = t.mcu_resets.front();
    const uint64_t stale = uint64_t(t.f_cpu_hz / 10);
    const auto first =
        std::find_if(t.replies.begin(), t.replies.end(), [&](const auto &r) { return r.cycle > reset + stale; });
    REQUIRE(first != t.replies.end());
    const double boot_ms = double(first->cycle - reset) * 1e3 / t.f_cpu_hz;
    INFO("capabilities reached the host " << boot_ms << " ms after the reset");
    CHECK(boot_ms > (board == "uno" ? 1375.0 : 833.0));
    CHECK(boot_ms < (board == "uno" ? 1375.0 : 833.0) + 10.0);  // the firmware's start, a 16U2 batch
    CHECK(std::none_of(t.frame_ends.begin(), t.frame_ends.end(), [&](uint64_t c) { return c < first->cycle; }));
    bool lost_none = false;
    for (const std::string &line : t.summary_lines)
      if (line.find("uart_in_lost=0 ") != std::string::npos) lost_none = true;
    CHECK(lost_none);
  }
  // The contrast: a hello sent at once after the open is lost in the Uno's bootloader (1.4 s),
  // which outlasts hello's three tries.
  VboardProcess vb({"--board", "uno", "--auto-reset", "--seconds", "30", "--quiet"});  // in real time
  Board b(open_link(vb.pty()));
  CHECK_THROWS(b.hello(1200));
  CHECK(b.greet().motor_count == 4);  // its announcement still waits in the pty
}

TEST_CASE("link: bytes that reach a Mega's bootloader hold it until 5 s of silence, and an Uno's does not",
          "[e2e][pacing]") {
  for (const std::string board : {"uno", "mega"}) {
    INFO(board);
    const std::string trace_path = e2e::scratch("boot-held-" + board + ".csv");
    {
      VboardProcess vb({"--board", board, "--auto-reset", "--link-model", "16u2", "--seconds", "30", "--trace",
                        trace_path, "--trace-frames", "--quiet", "--no-measure"});  // in real time
      Board b(open_link(vb.pty()));
      // Three hellos, 0.4 s apart from the open on: the bootloader loses each.
      CHECK_THROWS(b.hello(1200));
      CHECK(b.greet(7000).motor_count == (board == "uno" ? 4u : 5u));
      REQUIRE(vb.stop() == 0);
    }
    const tr::Trace t = tr::read_trace(trace_path);
    REQUIRE(t.mcu_resets.size() == 1);
    const uint64_t reset = t.mcu_resets.front();
    const auto first = std::find_if(t.replies.begin(), t.replies.end(),
                                    [&](const auto &r) { return r.cycle > reset + uint64_t(t.f_cpu_hz / 10); });
    REQUIRE(first != t.replies.end());
    const double boot_ms = double(first->cycle - reset) * 1e3 / t.f_cpu_hz;
    INFO("the firmware's capabilities reached the host " << boot_ms << " ms after the reset");
    if (board == "uno") {
      CHECK(boot_ms < 1375.0 + 10.0);  // optiboot ignores them (framing errors at its baud rate)
    } else {
      CHECK(boot_ms > 800.0 + 5000.0);  // the last hello about 0.8 s after the reset
      CHECK(boot_ms < 900.0 + 5000.0 + 100.0);
    }
  }
}

TEST_CASE("link: with --no-auto-reset the host's opens leave the board running") {
  const std::string trace_path = e2e::scratch("no-reset.csv");
  {
    VboardProcess vb({"--board", "uno", "--no-auto-reset", "--link-model", "16u2", "--no-pacing", "--seconds", "30",
                      "--trace", trace_path, "--trace-frames", "--quiet"});
    for (uint8_t i = 0; i < 3; ++i) {  // three opens, each answered at once
      Board b(open_link(vb.pty()));
      b.hello();
      e2e::board_ticks(b, i);
    }
    REQUIRE(vb.stop() == 0);
  }
  const tr::Trace t = tr::read_trace(trace_path);
  CHECK(t.mcu_resets.empty());
  CHECK(t.frame_ends.size() >= 6);  // each open's hello and clock request reached the firmware
}

TEST_CASE("link: stepchoir hello greets an Uno and a Mega that its open resets") {
  for (const std::string board : {"uno", "mega"}) {
    const std::string trace_path = e2e::scratch("greet-" + board + ".csv");
    {
      VboardProcess vb({"--board", board, "--auto-reset", "--link-model", "16u2", "--trace", trace_path,
                        "--trace-frames", "--quiet"});
      stepchoir::ChildProcess cli({STEPCHOIR_BIN, "hello", "--port", vb.pty()}, true);
      const std::string out = cli.read_rest(10000);
      INFO(out);
      CHECK(cli.wait() == 0);
      CHECK(out.find(board == "uno" ? "uno_cnc_shield_v3" : "mega_ramps_14") != std::string::npos);
      REQUIRE(vb.stop() == 0);
    }
    // It sent no hello: the capabilities the firmware sent after the bootloader answered (without
    // them it would have asked with hello after 2 s: more frames in the trace). Its only frames
    // ask for the board's id and give the new board one (config/board_memory.h).
    const tr::Trace t = tr::read_trace(trace_path);
    CHECK(t.mcu_resets.size() == 1);
    CHECK(t.frame_ends.size() == 2);
  }
}

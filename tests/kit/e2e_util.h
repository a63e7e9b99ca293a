// e2e_util.h: helpers for end-to-end tests: a host session on a virtual board, traffic
// generators, and board-clock scheduling.
#ifndef STEPCHOIR_TESTS_E2E_UTIL_H
#define STEPCHOIR_TESTS_E2E_UTIL_H

#include <atomic>
#include <optional>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "board/board.h"
#include "core/pitch.h"
#include "vboard_process.h"

namespace e2e {

// A scratch path for a trace, unique per test.
inline std::string scratch(const std::string &name) {
  return std::string(STEPCHOIR_E2E_SCRATCH) + "/" + name;
}

// The board's clock now (ticks), through a clock request.
inline uint32_t board_ticks(stepchoir::Board &b, uint8_t seq = 1) {
  b.send({sc::kMsgClockReq, seq});
  auto r = b.wait_reply(sc::kMsgClock, 5000);
  if (!r) throw std::runtime_error("no clock reply");
  return sc::get_u32(&(*r)[2]);
}

// An `at` payload: entries start at board time at_ticks.
inline std::vector<uint8_t> at_payload(uint32_t at_ticks, const std::vector<sc::PeriodEntry> &entries) {
  return stepchoir::at_payload(at_ticks, entries);
}

// Sends frames back to back until the board process exits, `stop` is set, or (until_ticks not
// 0) a clock reply shows board time at until_ticks or later, draining replies: heartbeats and
// status requests, the traffic a host keeps up while music plays, and a clock request a round
// when until_ticks is set. The last status reply seen goes to *last_status; the `late` errors
// the board answered (a timed entry taken after its time) are counted in *late_replies.
inline size_t flood_until_exit(stepchoir::Board &b, VboardProcess &vb, std::atomic<bool> *stop = nullptr,
                               std::optional<stepchoir::Status> *last_status = nullptr,
                               int pause_us = 0, uint32_t until_ticks = 0, int *late_replies = nullptr) {
  const auto hb = stepchoir::frame({sc::kMsgHeartbeat});
  const auto st = stepchoir::frame({sc::kMsgStatusReq});
  const auto clock = stepchoir::frame({sc::kMsgClockReq, 0x5C});
  std::vector<uint8_t> burst;  // paced: one heartbeat and one status request a round
  const int heartbeats = pause_us ? 1 : 64;
  for (int i = 0; i < heartbeats; ++i) burst.insert(burst.end(), hb.begin(), hb.end());
  burst.insert(burst.end(), st.begin(), st.end());
  if (until_ticks) burst.insert(burst.end(), clock.begin(), clock.end());
  const size_t per_burst = size_t(heartbeats + 1 + (until_ticks ? 1 : 0));
  size_t frames = 0;
  uint8_t sink[4096];
  sc::FrameDecoder dec;
  bool past = false;
  for (bool more = true; more;) {
    more = vb.running() && !(stop && *stop) && !past;
    if (more && !b.link().write(burst.data(), burst.size())) break;
    frames += more ? per_burst : 0;
    if (more && pause_us) std::this_thread::sleep_for(std::chrono::microseconds(pause_us));
    long n;
    while ((n = b.link().read(sink, sizeof sink, more ? 0 : 50)) > 0) {
      for (long i = 0; i < n; ++i) {
        if (dec.push(sink[i]) != sc::kFrameOk) continue;
        const uint8_t *p = dec.payload();
        if (until_ticks && p[0] == sc::kMsgClock && dec.payload_len() >= 6 &&
            static_cast<int32_t>(sc::get_u32(&p[2]) - until_ticks) >= 0)
          past = true;
        if (late_replies && p[0] == sc::kMsgError && dec.payload_len() >= 2 && p[1] == sc::kErrLate) ++*late_replies;
        if (!last_status || p[0] != sc::kMsgStatus) continue;
        try {
          *last_status = stepchoir::parse_status(p, dec.payload_len());
        } catch (const std::exception &) {
        }
      }
    }
  }
  return frames;
}

}  // namespace e2e

#endif  // STEPCHOIR_TESTS_E2E_UTIL_H

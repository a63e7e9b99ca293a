// link_budget.h: the bytes a writer may put on one board's link (a token bucket), pure.
//
// The firmware's main loop cannot take frames as fast as the line carries them, so every byte
// a board's writer or engine puts on the link is charged here: credit refills at
// sc::kLinkBudgetBytesPerSecond up to sc::kLinkBurstBytes (protocol/stepchoir_protocol.h says
// how those were measured). Beyond the budget the writer coalesces (coalescer.h).
#ifndef STEPCHOIR_HOST_LIVE_LINK_BUDGET_H
#define STEPCHOIR_HOST_LIVE_LINK_BUDGET_H

#include <cstddef>
#include <cstdint>

#include "stepchoir_protocol.h"

namespace stepchoir {

// Called from: the holder of its board's link ownership (board_link.h). Does not allocate.
class LinkBudget {
 public:
  static constexpr int64_t kBytesPerSecond = sc::kLinkBudgetBytesPerSecond;
  static constexpr int64_t kBurstBytes = sc::kLinkBurstBytes;
  // Adds the credit earned since the last call (now_us: monotonic_us()).
  void refill(uint64_t now_us) noexcept;
  // True when a frame may go now (the budget may then go negative by that frame's bytes).
  bool can_send() const noexcept { return credit_ >= 0; }
  // Whole bytes of credit now (negative when overspent).
  int64_t credit_bytes() const noexcept { return credit_ / kMicro; }
  void spend(size_t bytes) noexcept { credit_ -= static_cast<int64_t>(bytes) * kMicro; }
  // How long until can_send(), in us (0 when it already can).
  uint64_t wait_us() const noexcept;

 private:
  static constexpr int64_t kMicro = 1000000;  // credit in millionths of a byte, so that
  int64_t credit_ = kBurstBytes * kMicro;     // 1 us adds exactly kBytesPerSecond
  uint64_t last_us_ = 0;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_LINK_BUDGET_H

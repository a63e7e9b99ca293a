// link_budget.cpp: LinkBudget's refill and wait.
#include "live/link_budget.h"

#include <algorithm>

namespace stepchoir {

void LinkBudget::refill(uint64_t now_us) noexcept {
  if (last_us_ != 0 && now_us > last_us_) {
    const uint64_t elapsed_us = std::min<uint64_t>(now_us - last_us_, 10 * kMicro);  // no overflow
    credit_ = std::min(kBurstBytes * kMicro, credit_ + static_cast<int64_t>(elapsed_us) * kBytesPerSecond);
  }
  last_us_ = now_us;
}

uint64_t LinkBudget::wait_us() const noexcept {
  return credit_ >= 0 ? 0 : static_cast<uint64_t>((-credit_ + kBytesPerSecond - 1) / kBytesPerSecond);
}

}  // namespace stepchoir

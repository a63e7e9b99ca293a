// latency_histogram.cpp: LatencyHistogram's record and percentile.
#include "live/latency_histogram.h"

#include <cmath>

namespace stepchoir {

void LatencyHistogram::record(uint64_t us) noexcept {
  bins_[us < kBins ? us : kBins - 1].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  uint64_t m = max_.load(std::memory_order_relaxed);
  while (us > m && !max_.compare_exchange_weak(m, us, std::memory_order_relaxed)) {
  }
}

uint64_t LatencyHistogram::percentile(double q) const noexcept {
  const uint64_t n = count();
  if (n == 0) return 0;
  const uint64_t rank = q <= 0 ? 1 : static_cast<uint64_t>(std::ceil(q * static_cast<double>(n)));
  uint64_t seen = 0;
  for (size_t i = 0; i < kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen >= rank) return i;
  }
  return kBins - 1;
}

}  // namespace stepchoir

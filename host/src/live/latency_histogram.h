// latency_histogram.h: latency samples for the live path's figures, lock-free.
#ifndef STEPCHOIR_HOST_LIVE_LATENCY_HISTOGRAM_H
#define STEPCHOIR_HOST_LIVE_LATENCY_HISTOGRAM_H

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace stepchoir {

// Latency samples in 1 us bins up to 20 ms (more is counted as 20 ms). Lock-free: the engine
// and writer threads record, any thread reads (relaxed; figures may trail by a sample).
class LatencyHistogram {
 public:
  static constexpr size_t kBins = 20000;
  // Called from: the engine and writer threads. Does not allocate or block.
  void record(uint64_t us) noexcept;
  // Nearest-rank percentile (q in [0, 1]) in us; 0 with no samples. Called from: any thread.
  uint64_t percentile(double q) const noexcept;
  uint64_t max_us() const noexcept { return max_.load(std::memory_order_relaxed); }
  uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }

 private:
  std::array<std::atomic<uint32_t>, kBins> bins_{};
  std::atomic<uint64_t> count_{0}, max_{0};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_LATENCY_HISTOGRAM_H

// clock_sync.cpp: least-squares fit of the board's clock against the host's.
#include "player/clock_sync.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace stepchoir {

bool ClockSync::add(uint64_t send_us, uint64_t recv_us, uint32_t board_ticks) {
  const double mid = 0.5 * (static_cast<double>(send_us) + static_cast<double>(recv_us));
  const double rtt = recv_us > send_us ? static_cast<double>(recv_us - send_us) : 0.0;
  if (samples_.empty()) {
    samples_.push_back({mid, static_cast<double>(board_ticks), rtt});
    origin_us_ = mid;
    offset_ticks_ = board_ticks;
    return true;
  }
  // Unwrap against the prediction: the board's counter wraps every 2^32 ticks.
  const double predicted = ticks_at(mid);
  const double wrap = 4294967296.0;
  const double ticks = board_ticks + std::round((predicted - board_ticks) / wrap) * wrap;
  // A board that restarted counts from 0 again: its time goes backwards. (One that only fell
  // behind for a moment, like a stalled virtual board, still counts forwards: the fit follows.)
  const double back_s = (samples_.back().ticks - ticks) / rate_ - (rtt + samples_.back().rtt_us) / 1e6;
  if (back_s > reset_jump_s_) {
    if (++outliers_ >= 2) return false;
    return true;  // one odd sample: wait for the next before calling it a new board
  }
  outliers_ = 0;
  samples_.push_back({mid, ticks, rtt});
  while (samples_.size() > window_) samples_.pop_front();
  fit();
  return true;
}

void ClockSync::reset() {
  samples_.clear();
  rate_ = nominal_;
  has_rate_ = false;
  origin_us_ = offset_ticks_ = residual_us_ = 0;
  outliers_ = 0;
}

double ClockSync::min_rtt_us() const {
  double m = 0;
  for (size_t i = 0; i < samples_.size(); ++i) m = i == 0 ? samples_[i].rtt_us : std::min(m, samples_[i].rtt_us);
  return m;
}

// Called from: add. Keeps the samples with the shortest round trips (the fastest quarter, or
// all within 100 us of the shortest: a delay on one way only moves a midpoint by half of
// it), then fits ticks = offset + rate * (host - origin).
void ClockSync::fit() {
  std::vector<double> rtts;
  rtts.reserve(samples_.size());
  for (const Sample &s : samples_) rtts.push_back(s.rtt_us);
  std::nth_element(rtts.begin(), rtts.begin() + rtts.size() / 4, rtts.end());
  const double limit = std::max(rtts[rtts.size() / 4], min_rtt_us() + 100.0);
  double n = 0, sum_h = 0, sum_t = 0, first = 0, last = 0;
  for (const Sample &s : samples_) {
    if (s.rtt_us > limit) continue;
    if (n == 0) first = s.host_us;
    last = s.host_us;
    n += 1;
    sum_h += s.host_us;
    sum_t += s.ticks;
  }
  const double mean_h = sum_h / n, mean_t = sum_t / n;
  if (n >= 3 && (last - first) >= min_rate_span_s_ * 1e6) {
    double sxx = 0, sxy = 0;
    for (const Sample &s : samples_) {
      if (s.rtt_us > limit) continue;
      sxx += (s.host_us - mean_h) * (s.host_us - mean_h);
      sxy += (s.host_us - mean_h) * (s.ticks - mean_t);
    }
    if (sxx > 0) {
      rate_ = sxy / sxx * 1e6;
      has_rate_ = true;
    }
  }
  origin_us_ = mean_h;
  offset_ticks_ = mean_t;
  double sq = 0;
  for (const Sample &s : samples_) {
    if (s.rtt_us > limit) continue;
    const double e_us = (s.ticks - ticks_at(s.host_us)) * 1e6 / rate_;
    sq += e_us * e_us;
  }
  residual_us_ = std::sqrt(sq / n);
}

}  // namespace stepchoir

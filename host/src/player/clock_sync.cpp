// clock_sync.cpp: least-squares fit of the board's clock against the host's.
#include "player/clock_sync.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace stepchoir {

bool ClockSync::add(uint64_t send_us, uint64_t recv_us, uint32_t board_ticks) {
  const double send = static_cast<double>(send_us);
  const double rtt = recv_us > send_us ? static_cast<double>(recv_us - send_us) : 0.0;
  if (samples_.empty()) {
    samples_.push_back({send, static_cast<double>(board_ticks), rtt});
    origin_us_ = send;
    offset_ticks_ = board_ticks;
    return true;
  }
  // Unwrap against the prediction: the board's counter wraps every 2^32 ticks.
  const double predicted = ticks_at(send);
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
  // The board stamps a request between its send and its reply: off the line by more than that
  // and kStepMinUs, kStepSamples times in a row on the same side, its clock stepped (time a
  // stalled simulation gave up): the fit starts again from those samples, keeping the rate.
  // (One that fell behind for a moment and caught up is left out by the fit's trim.)
  const double off_us = (ticks - ticks_at(send)) * 1e6 / rate_;
  const double margin_us = std::max(kStepMinUs, 4 * residual_us_);
  if (off_us < -margin_us || off_us > rtt + margin_us) {
    const int side = off_us > 0 ? 1 : -1;
    off_line_ = off_line_ * side > 0 ? off_line_ + side : side;
  } else {
    off_line_ = 0;
  }
  samples_.push_back({send, ticks, rtt});
  if (std::abs(off_line_) >= kStepSamples) {
    samples_.erase(samples_.begin(), samples_.end() - std::abs(off_line_));
    off_line_ = 0;
  }
  while (samples_.size() > window_ || samples_.back().host_us - samples_.front().host_us > kWindowS * 1e6)
    samples_.pop_front();
  fit();
  if (way_ == Way::kSendSide) settle_on_quickest();
  return true;
}

// Called from: add, after fit. The fit's points are each a few samples' median way out, which
// puts the line about half a USB frame's wait behind the quickest way out. The line is moved,
// along its slope, to the kQuickestQuantile of every sample's distance from it: the board's
// time as a request that caught its frame at once reaches it (a tenth of a frame's wait at
// most), the same point on every board's link, so the notes of several boards line up. (A
// request held up on its way out, or a reply kept by the bridge, is among the slow ones and
// weighs nothing; a board that fell behind for a moment is among the quick ones only while the
// moments are fewer than the quantile.)
void ClockSync::settle_on_quickest() {
  if (samples_.size() < kQuickestMinSamples) return;
  std::vector<double> off;
  off.reserve(samples_.size());
  for (const Sample &s : samples_) off.push_back(s.ticks - ticks_at(s.host_us));
  const auto q = off.begin() + static_cast<std::ptrdiff_t>(static_cast<double>(off.size()) * kQuickestQuantile);
  std::nth_element(off.begin(), q, off.end());
  offset_ticks_ += *q;
}

void ClockSync::reset() {
  samples_.clear();
  rate_ = has_prior() ? prior_rate_ : nominal_;
  has_rate_ = has_prior();
  origin_us_ = offset_ticks_ = residual_us_ = 0;
  rate_sigma_ppm_ = has_prior() ? prior_sigma_ppm_ : 1e6;
  outliers_ = off_line_ = 0;
}

void ClockSync::set_prior(double ticks_per_s, double sigma_ppm) {
  if (!(ticks_per_s > 0) || !(sigma_ppm >= 0)) return;
  prior_rate_ = ticks_per_s;
  prior_sigma_ppm_ = std::max(sigma_ppm, kPriorMinSigmaPpm);
  if (samples_.empty()) reset();
}

double ClockSync::min_rtt_us() const {
  double m = 0;
  for (size_t i = 0; i < samples_.size(); ++i) m = i == 0 ? samples_[i].rtt_us : std::min(m, samples_[i].rtt_us);
  return m;
}

namespace {

// A point of the fit: host time (us), board ticks.
struct Point {
  double host_us, ticks;
};

// Least-squares line ticks = mean_t + slope * (host - mean_h) through the points kept.
struct Line {
  double n = 0, mean_h = 0, mean_t = 0, slope = 0, span_us = 0, sxx = 0;
  double at(double host_us) const { return mean_t + slope * (host_us - mean_h); }
};

Line fit_line(const std::vector<Point> &points, const std::vector<bool> &keep, double fallback_slope) {
  Line l;
  double sum_h = 0, sum_t = 0, first = 0, last = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    if (l.n == 0) first = points[i].host_us;
    last = points[i].host_us;
    l.n += 1;
    sum_h += points[i].host_us;
    sum_t += points[i].ticks;
  }
  if (l.n == 0) return l;
  l.mean_h = sum_h / l.n;
  l.mean_t = sum_t / l.n;
  l.span_us = last - first;
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    sxx += (points[i].host_us - l.mean_h) * (points[i].host_us - l.mean_h);
    sxy += (points[i].host_us - l.mean_h) * (points[i].ticks - l.mean_t);
  }
  l.slope = l.n >= 3 && sxx > 0 ? sxy / sxx : fallback_slope;
  l.sxx = sxx;
  return l;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

// Called from: add. The points: of each point_samples in a row, the one whose board time is
// the median distance ahead of its send time (the way out varies by up to a USB frame, evenly
// over the frame as the requests' send times step through it; a request held up on its way
// out and a board that fell behind for a moment sit at the ends); with kRoundTrip,
// every sample whose round trip is among the quickest quarter (or within 100 us of the
// quickest), at its midpoint. A line through them; points off it by more than four times
// their typical distance (at least kTrimMinUs) are left out and the line fitted again,
// twice. The rate is taken once the points span min_rate_span_s.
void ClockSync::fit() {
  const double per_us = rate_ / 1e6;
  std::vector<Point> points;
  if (way_ == Way::kRoundTrip) {  // every sample of about the quickest round trips, at its midpoint
    std::vector<double> rtts;
    for (const Sample &s : samples_) rtts.push_back(s.rtt_us);
    std::nth_element(rtts.begin(), rtts.begin() + static_cast<std::ptrdiff_t>(rtts.size() / 4), rtts.end());
    const double limit = std::max(rtts[rtts.size() / 4], min_rtt_us() + 100.0);
    for (const Sample &s : samples_)
      if (s.rtt_us <= limit) points.push_back({s.host_us + s.rtt_us / 2, s.ticks});
  }
  for (size_t first = 0; way_ == Way::kSendSide && first < samples_.size(); first += point_samples_) {
    const size_t end = std::min(samples_.size(), first + point_samples_);
    std::vector<const Sample *> group;
    for (size_t i = first; i < end; ++i) group.push_back(&samples_[i]);
    const auto mid = group.begin() + static_cast<std::ptrdiff_t>(group.size() / 2);
    std::nth_element(group.begin(), mid, group.end(), [per_us](const Sample *a, const Sample *b) {
      return a->ticks - a->host_us * per_us < b->ticks - b->host_us * per_us;
    });
    points.push_back({(*mid)->host_us, (*mid)->ticks});
  }
  std::vector<bool> kept(points.size(), true);
  Line l = fit_line(points, kept, per_us);
  for (int pass = 0; pass < 2 && points.size() >= 3; ++pass) {
    std::vector<double> off(points.size());
    for (size_t i = 0; i < points.size(); ++i) off[i] = (points[i].ticks - l.at(points[i].host_us)) / per_us;
    const double centre = median(off);
    std::vector<double> dist(points.size());
    for (size_t i = 0; i < points.size(); ++i) dist[i] = std::fabs(off[i] - centre);
    const double band = std::max(kTrimMinUs, 4 * 1.4826 * median(dist));
    for (size_t i = 0; i < points.size(); ++i) kept[i] = dist[i] <= band;
    const Line trimmed = fit_line(points, kept, per_us);
    if (trimmed.n == 0) break;
    l = trimmed;
  }
  const bool fitted = l.n >= 3 && l.span_us >= min_rate_span_s_ * 1e6 && l.slope > 0;
  if (fitted) {
    rate_ = l.slope * 1e6;
    has_rate_ = true;
  } else if (has_prior()) {
    rate_ = prior_rate_;
  }
  origin_us_ = l.mean_h;
  offset_ticks_ = l.mean_t;
  double sq = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!kept[i]) continue;
    const double e_us = (points[i].ticks - ticks_at(points[i].host_us)) * 1e6 / rate_;
    sq += e_us * e_us;
  }
  residual_us_ = std::sqrt(sq / l.n);
  rate_sigma_ppm_ = has_rate_ && l.n >= 3 && l.sxx > 0 ? residual_us_ / std::sqrt(l.sxx) * 1e6 : 1e6;
  if (!has_prior()) return;
  if (!fitted) {
    rate_sigma_ppm_ = prior_sigma_ppm_;
    return;
  }
  // Weigh the samples' rate against the prior; the line keeps its centre.
  const double fit_sigma = std::max(rate_sigma_ppm_, kPriorSpanErrors * residual_us_ / l.span_us * 1e6);
  const double apart_ppm = std::fabs(rate_ - prior_rate_) / nominal_ * 1e6;
  if (apart_ppm > kPriorRejectSigmas * std::hypot(fit_sigma, prior_sigma_ppm_)) {
    clear_prior();
    return;
  }
  const double wf = 1 / (fit_sigma * fit_sigma), wp = 1 / (prior_sigma_ppm_ * prior_sigma_ppm_);
  rate_ = (wf * rate_ + wp * prior_rate_) / (wf + wp);
  rate_sigma_ppm_ = 1 / std::sqrt(wf + wp);
}

}  // namespace stepchoir

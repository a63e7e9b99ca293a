// midi_clock.cpp: see midi_clock.h.
#include "player/midi_clock.h"

#include <algorithm>
#include <cmath>

namespace stepchoir {

void ClockFollower::take(const ClockMessage &m) {
  switch (m.status) {
    case kMidiClockTick: {
      const double us = static_cast<double>(m.t_us);
      if (count_ >= 2 && slope_ > 0) {
        const double gap = (us - last_us_) / slope_;  // in the grid's tick periods
        if (pending_lost_ > 0) {  // the last tick came after a long gap: on time, or late?
          if (gap < 0.5) {  // late, with this one: out of the fit
            --next_;
            --count_;
          } else if (std::fabs(gap - 1) < kLostSlack && lost_fits_better(us)) {  // on time: ticks lost
            ring_[(next_ - 1) % kWindow].n += pending_lost_;
            ticks_ += pending_lost_;
            lost_ += static_cast<uint64_t>(pending_lost_);
          }  // else both late by less each time, or the clock slowed down (note_change sees that)
          pending_lost_ = 0;
        }
        last_us_ = us;
        if (gap < 0.5) {  // held up and delivered with the one before: counted, not fitted
          ++ticks_;
          break;
        }
        const int64_t whole = std::llround(gap);
        if (whole >= 2 && whole <= kMaxLostRun) pending_lost_ = whole - 1;
      }
      last_us_ = us;
      note_change(us);
      ring_[next_ % kWindow] = {ticks_, us};
      ++next_;
      ++ticks_;
      count_ = std::min(count_ + 1, kWindow);
      fit();
      break;
    }
    case kMidiClockStart:  // the next tick is beat 0
      zero_tick_ = ticks_;
      start_beat_ = 0;
      running_ = true;
      ++starts_;
      break;
    case kMidiClockContinue:  // the next tick is the song position's
      start_beat_ = position_ / 4.0;
      zero_tick_ = ticks_ - static_cast<int64_t>(position_) * (kTicksPerBeat / 4);
      running_ = true;
      ++starts_;
      break;
    case kMidiClockStop:
      running_ = false;
      break;
    case kMidiSongPosition:
      position_ = m.position;
      break;
    default:
      break;
  }
}

// Called from: take, for the tick after one that came after a long gap (us: when it came). Are
// the two on the line with pending_lost_ ticks lost before them (both on time), closer than
// without (both held up, the second less)? Squared distances from the line (the long-gap tick is
// one of up to kWindow ticks in it).
bool ClockFollower::lost_fits_better(double us) const {
  const Tick &last = ring_[(next_ - 1) % kWindow];
  const double n = static_cast<double>(last.n), lost = static_cast<double>(pending_lost_);
  const auto sq = [](double x) { return x * x; };
  const double held = sq(last.us - (intercept_ + slope_ * n)) + sq(us - (intercept_ + slope_ * (n + 1)));
  const double gone =
      sq(last.us - (intercept_ + slope_ * (n + lost))) + sq(us - (intercept_ + slope_ * (n + lost + 1)));
  return gone < held;
}

// Called from: take, for a tick about to join the fit (us: when it came). A tick more than
// kChangeUs off the line, after another off it the same way but less far, is a tempo change
// (the clock's jitter, a millisecond or two, never goes that far twice in a row; ticks a stalled
// path held up come back towards the line): the fit forgets the ticks
// before the change and keeps the last one on the old line, at its time on that line (a
// fraction of the jitter off), where the new tempo turns, so the new tempo takes over within a
// few ticks rather than a beat.
void ClockFollower::note_change(double us) {
  if (count_ < kChangeMinTicks) {
    change_run_ = 0;
    return;
  }
  const double residual = us - (intercept_ + slope_ * static_cast<double>(ticks_));
  const int sign = residual > 0 ? 1 : -1;
  // A new tempo's ticks go further off the line each time; ticks held up by a stalled path
  // come back to it.
  const bool further = std::fabs(residual) > std::fabs(change_residual_);
  change_residual_ = residual;
  if (std::fabs(residual) <= kChangeUs || (change_run_ > 0 && (sign != change_sign_ || !further))) {
    change_run_ = std::fabs(residual) > kChangeUs ? 1 : 0;
    change_sign_ = sign;
    return;
  }
  change_sign_ = sign;
  if (++change_run_ < 2) return;
  count_ = hinge_back(us) + 1;  // the anchor and the ticks after it
  Tick &anchor = ring_[(next_ - count_) % kWindow];
  anchor.us = intercept_ + slope_ * static_cast<double>(anchor.n);
  change_run_ = 0;
}

// Called from: note_change, at a tempo change (us: the tick coming now). The change began at a
// tick the old line still holds, a few ticks before it was seen (a small change grows past
// kChangeUs slowly, and jitter hides its first tick): of the last kHingeTicks ticks, the one
// after which this tick and those before it best follow one new tempo from the old line (least
// squares of the two parts). Returns its place back from the newest tick in the ring (0: it).
size_t ClockFollower::hinge_back(double us) const {
  const size_t m = std::min(count_, kHingeTicks);
  std::array<double, kHingeTicks + 1> n{}, t{};  // the last m ticks, oldest first, then this one
  for (size_t i = 0; i < m; ++i) {
    const Tick &k = ring_[(next_ - m + i) % kWindow];
    n[i] = static_cast<double>(k.n);
    t[i] = k.us;
  }
  n[m] = static_cast<double>(ticks_);
  t[m] = us;
  double best_rss = 0;
  size_t best = m - 1;
  for (size_t j = 0; j < m; ++j) {  // tick j the last on the old line
    double rss = 0;
    for (size_t k = 0; k <= j; ++k) rss += std::pow(t[k] - (intercept_ + slope_ * n[k]), 2);
    const double at = intercept_ + slope_ * n[j];
    double sxy = 0, sxx = 0;
    for (size_t k = j + 1; k <= m; ++k) {
      sxy += (n[k] - n[j]) * (t[k] - at);
      sxx += (n[k] - n[j]) * (n[k] - n[j]);
    }
    const double tick_us = sxy / sxx;  // the new tempo's tick
    for (size_t k = j + 1; k <= m; ++k) rss += std::pow(t[k] - at - tick_us * (n[k] - n[j]), 2);
    if (j == 0 || rss < best_rss) best_rss = rss, best = j;
  }
  return m - 1 - best;
}

// Least squares through the ring's ticks: t = intercept_ + slope_ * n.
void ClockFollower::fit() {
  if (count_ < 2) return;
  // Relative to the oldest tick in the ring (sums of small numbers: no cancellation).
  const Tick &oldest = ring_[(next_ - count_) % kWindow];
  double sn = 0, st = 0, snn = 0, snt = 0;
  for (size_t i = next_ - count_; i < next_; ++i) {
    const Tick &k = ring_[i % kWindow];
    const double x = static_cast<double>(k.n - oldest.n), t = k.us - oldest.us;
    sn += x, st += t, snn += x * x, snt += x * t;
  }
  const double k = static_cast<double>(count_);
  slope_ = (k * snt - sn * st) / (k * snn - sn * sn);
  intercept_ = oldest.us + (st - slope_ * sn) / k - slope_ * static_cast<double>(oldest.n);
}

double ClockFollower::host_us_at(double beat) const {
  return intercept_ + slope_ * (static_cast<double>(zero_tick_) + beat * kTicksPerBeat);
}

double ClockFollower::beat_at(double host_us) const {
  return ((host_us - intercept_) / slope_ - static_cast<double>(zero_tick_)) / kTicksPerBeat;
}

MidiClockTimeline::MidiClockTimeline(ClockQueue &queue, std::vector<TempoPoint> tempo, double speed)
    : queue_(queue), speed_(speed) {
  tempo_song_.tempo = std::move(tempo);
}

void MidiClockTimeline::poll() {
  ClockMessage m;
  while (queue_.try_dequeue(m)) follower_.take(m);
}

double MidiClockTimeline::start_score_s() const { return song_seconds(tempo_song_, follower_.start_beat()) / speed_; }

double MidiClockTimeline::host_us(double score_s) const {
  return follower_.host_us_at(song_beat(tempo_song_, score_s * speed_));
}

double MidiClockTimeline::score_at(double host_us) const {
  return song_seconds(tempo_song_, follower_.beat_at(host_us)) / speed_;
}

}  // namespace stepchoir

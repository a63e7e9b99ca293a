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
        // Within kTwinUs of the one before and, counted, half a period or more ahead of the
        // line: the same tick again (JACK hands a client that missed its cycle the cycle's
        // events twice), not a new one.
        if (gap < 0.5 && us - last_us_ < kTwinUs && held_count_ == 0 &&
            us < line_us(ticks_) - 0.5 * slope_) {
          ++twins_;
          break;
        }
        if (held_count_ > 0) {  // ticks that came after long gaps: on time after lost ones, or late?
          if (gap < 0.5) {      // the last came with this one: it was late, and stays out of the fit
            --held_count_;
            join_held(false);
          } else if (std::fabs(gap - 1) < kLostSlack) {  // this one a period on: lost ones, if they fit so
            join_held(lost_fits_better(us));
          } else if (gap < 1.5 || std::llround(gap) > kMaxLostRun || held_count_ == kMaxHeld) {
            join_held(false);  // late by less each time, or the clock slowed down (note_change sees that)
          }  // else after a long gap too: held with them below, and the next tells
        }
        last_us_ = us;
        // Right after the one before and not early (early: a tempo over twice as fast, for the
        // fit to follow): held up and delivered with it, counted, not fitted.
        if (gap < 0.5 && us > line_us(ticks_) - kChangeUs) {
          ++ticks_;
          break;
        }
        const int64_t whole = std::llround(gap);
        if (whole >= 2 && whole <= kMaxLostRun) {  // out of the fit until a tick a period on tells why
          held_[held_count_++] = {{ticks_, us}, whole - 1};
          ++ticks_;
          break;
        }
      }
      last_us_ = us;
      join({ticks_, us});
      ++ticks_;
      break;
    }
    case kMidiClockStart:  // the next tick is beat 0
      held_before_start_ = held_count_;
      zero_tick_ = ticks_;
      start_beat_ = 0;
      running_ = true;
      ++starts_;
      break;
    case kMidiClockContinue:  // the next tick is the song position's
      held_before_start_ = held_count_;
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

// Called from: take, for a tick that joins the fit (its number and when it came).
void ClockFollower::join(const Tick &tick) {
  note_change(tick);
  ring_[next_ % kWindow] = tick;
  ++next_;
  count_ = std::min(count_ + 1, kWindow);
  fit();
}

// Called from: take, once the tick after the held ones tells what they were. lost: each stands
// for the ticks its gap left out (they were lost on the way), else each came as it is (late, or
// a slower clock). Ticks found lost before a Start or Continue move its beat 0 with them.
void ClockFollower::join_held(bool lost) {
  int64_t shift = 0;
  for (size_t i = 0; i < held_count_; ++i) {
    if (lost) {
      shift += held_[i].lost;
      if (i < held_before_start_) zero_tick_ += held_[i].lost;
    }
    join({held_[i].tick.n + shift, held_[i].tick.us});
  }
  ticks_ += shift;
  lost_ += static_cast<uint64_t>(shift);
  held_count_ = 0;
  held_before_start_ = 0;
}

// Called from: take, for the tick a period after the last held one (us: when it came). Are
// they on the line with the ticks their gaps left out lost before each (all on time), closer than
// without (held up, and this one the next tick)? Squared distances from the line through the
// ticks before them.
bool ClockFollower::lost_fits_better(double us) const {
  const auto sq = [](double x) { return x * x; };
  double held = 0, gone = 0;
  int64_t shift = 0;
  for (size_t i = 0; i < held_count_; ++i) {
    shift += held_[i].lost;
    held += sq(held_[i].tick.us - line_us(held_[i].tick.n));
    gone += sq(held_[i].tick.us - line_us(held_[i].tick.n + shift));
  }
  held += sq(us - line_us(ticks_));
  gone += sq(us - line_us(ticks_ + shift));
  return gone < held;
}

// Called from: join, for a tick about to join the fit. kChangeRun ticks in a row more than
// kChangeUs off the line the same way, each further than the one before, are a tempo change
// (the clock's jitter, a millisecond or two, never goes that far twice in a row; ticks a stalled
// path held up come back towards the line, after two at most in the captures of
// tests/data/clock): the fit forgets the ticks
// before the change and keeps the last one on the old line, at its time on that line (a
// fraction of the jitter off), where the new tempo turns, so the new tempo takes over within a
// few ticks rather than a beat.
void ClockFollower::note_change(const Tick &tick) {
  if (count_ < kChangeMinTicks) {
    change_run_ = 0;
    return;
  }
  const double residual = tick.us - line_us(tick.n);
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
  if (++change_run_ < kChangeRun) return;
  ++changes_;
  count_ = hinge_back(tick) + 1;  // the anchor and the ticks after it
  Tick &anchor = ring_[(next_ - count_) % kWindow];
  anchor.us = line_us(anchor.n);
  change_run_ = 0;
}

// Called from: note_change, at a tempo change (tick: the one joining the fit now). The change began at a
// tick the old line still holds, a few ticks before it was seen (a small change grows past
// kChangeUs slowly, and jitter hides its first tick): of the last kHingeTicks ticks, the one
// after which this tick and those before it best follow one new tempo from the old line (least
// squares of the two parts). Returns its place back from the newest tick in the ring (0: it).
size_t ClockFollower::hinge_back(const Tick &tick) const {
  const size_t m = std::min(count_, kHingeTicks);
  std::array<double, kHingeTicks + 1> n{}, t{};  // the last m ticks, oldest first, then this one
  for (size_t i = 0; i < m; ++i) {
    const Tick &k = ring_[(next_ - m + i) % kWindow];
    n[i] = static_cast<double>(k.n);
    t[i] = k.us;
  }
  n[m] = static_cast<double>(tick.n);
  t[m] = tick.us;
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

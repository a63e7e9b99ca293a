// clock_sync.h: the board's clock as the host sees it: offset and rate estimated from clock
// round trips (pure; the player feeds it).
//
// Each clock request is stamped on the host when it is handed to the OS (send) and when its
// reply is decoded (recv); the board stamps it with its tick counter when it decoded it. The
// board's time at the host's midpoint (send + recv) / 2 is a sample; its error is at most half
// the round trip. Like an NTP/PTP client, the estimate keeps only the samples with the shortest
// round trips in a sliding window (a loaded host or link only lengthens round trips) and fits
// a line through them by least squares: the slope is the board's real tick rate (its crystal's
// error), the line the board's time at any host time. 32-bit tick counts are unwrapped against
// the prediction, so a song may last longer than the counter's 268 s period.
#ifndef STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H
#define STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H

#include <cstddef>
#include <cstdint>
#include <deque>

namespace stepchoir {

class ClockSync {
 public:
  static constexpr size_t kWindow = 500;          // samples kept (10 s at the player's 50 a second)
  static constexpr double kMinRateSpanS = 1.0;    // span of samples before the rate is fitted
  static constexpr double kResetJumpS = 0.05;     // the board's time this far back: a new board

  // nominal_ticks_per_s: the board's F_CPU (its tick rate if its crystal were exact).
  explicit ClockSync(double nominal_ticks_per_s) : nominal_(nominal_ticks_per_s), rate_(nominal_ticks_per_s) {}

  // Called from: the player thread, for each clock reply. Host times in us (monotonic_us).
  // Returns false (and keeps nothing) when the board's time went back by more than
  // kResetJumpS twice in a row: its clock restarted (a reset), the caller resets.
  bool add(uint64_t send_us, uint64_t recv_us, uint32_t board_ticks);

  // Forgets every sample (a new board). Called from: the player.
  void reset();
  // Keeps the last `samples` only and fits a rate once they span min_rate_span_s (a board
  // simulated as fast as it runs changes speed: a short window follows it). Called from: the
  // player, before the first sample.
  // reset_jump_s: how far back the board's time must go to mean a new board (kResetJumpS).
  void set_window(size_t samples, double min_rate_span_s, double reset_jump_s) {
    window_ = samples < 3 ? 3 : samples;
    min_rate_span_s_ = min_rate_span_s;
    reset_jump_s_ = reset_jump_s;
  }

  // True once a sample is in (before that, ticks_at is meaningless).
  bool ready() const { return !samples_.empty(); }
  size_t samples() const { return samples_.size(); }

  // The board's unwrapped tick count at a host time (us). Called from: the player.
  double ticks_at(double host_us) const { return offset_ticks_ + (host_us - origin_us_) * rate_ / 1e6; }
  // The host time (us) at which the board's unwrapped tick count reaches ticks.
  double host_us_at(double ticks) const { return origin_us_ + (ticks - offset_ticks_) * 1e6 / rate_; }
  // True once the rate is fitted (samples spanning min_rate_span_s).
  bool has_rate() const { return has_rate_; }
  // The board's ticks per real second, estimated (nominal until kMinRateSpanS of samples).
  double ticks_per_s() const { return rate_; }
  // The board's crystal error in parts per million, estimated.
  double ppm() const { return (rate_ / nominal_ - 1.0) * 1e6; }
  // Shortest round trip seen in the window, us.
  double min_rtt_us() const;
  // The fit's typical error: the RMS of the kept samples' residuals, us.
  double residual_us() const { return residual_us_; }

 private:
  struct Sample {
    double host_us;  // midpoint of the round trip
    double ticks;    // unwrapped board ticks
    double rtt_us;
  };
  void fit();

  double nominal_, rate_;
  double origin_us_ = 0, offset_ticks_ = 0;  // the line passes through (origin_us_, offset_ticks_)
  double residual_us_ = 0;
  std::deque<Sample> samples_;
  int outliers_ = 0;
  bool has_rate_ = false;
  size_t window_ = kWindow;
  double min_rate_span_s_ = kMinRateSpanS;
  double reset_jump_s_ = kResetJumpS;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H

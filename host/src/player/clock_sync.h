// clock_sync.h: the board's clock as the host sees it: offset and rate estimated from clock
// round trips (pure; the player feeds it).
//
// Each clock request is stamped on the host when it is handed to the OS (send) and when its
// reply is decoded (recv); the board stamps it with its tick counter when it decoded it, so
// the board's time lies between the two. Through a USB bridge the two ways differ: a request
// waits at most for the next 1 ms USB frame, a reply for the bridge's whole batching time (up
// to 4 ms on a 16U2, 16 ms on an FTDI). The fit therefore works from the send side, where a
// request waits only for the next frame: of every few samples in a row it takes the one whose
// board time is the median distance ahead of its send time (a request held up on its way
// out, or a board that fell behind for a moment as a stalled simulation does, is one of a
// few at either end) and fits a line through those by least squares, leaving out points far
// off it: the slope is the board's real tick rate (its crystal's error). The line is then
// moved to the quickest tenth of all the samples' ways out: the board's time as a request
// that caught its USB frame at once reaches it, the same point on every board's link. Samples
// off the line by tens of ms several times in a row mean the board's clock stepped, and the fit
// starts again from them with the rate it has. The window slides, so the fit keeps refining for
// as long as samples come. 32-bit tick counts are unwrapped against the prediction, so a song
// may last longer than the counter's 268 s period.
#ifndef STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H
#define STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H

#include <cstddef>
#include <cstdint>
#include <deque>

namespace stepchoir {

class ClockSync {
 public:
  static constexpr size_t kWindow = 2000;         // samples kept at most
  static constexpr double kWindowS = 10.0;        // samples kept from this much host time
  static constexpr double kMinRateSpanS = 1.0;    // span of samples before the rate is fitted
  static constexpr double kResetJumpS = 0.05;     // the board's time this far back: a new board
  static constexpr size_t kPointSamples = 8;      // one point of the fit per this many samples
  static constexpr double kTrimMinUs = 300;       // the fit keeps points this close to its line
  static constexpr double kStepMinUs = 20000;     // a sample this far off the line is off it
  static constexpr int kStepSamples = 5;          // off the line this often in a row: the clock stepped
  static constexpr double kPriorSpanErrors = 2;   // a fit's rate error: at least this many residuals over its span
  static constexpr double kPriorRejectSigmas = 3; // a prior this far from the samples' rate is dropped
  static constexpr double kPriorMinSigmaPpm = 10; // a prior is never surer than this (a crystal drifts with heat)
  static constexpr double kQuickestQuantile = 0.1; // kSendSide: the line at this quantile of the samples' way out
  static constexpr size_t kQuickestMinSamples = 10; // ... once this many samples are in

  // nominal_ticks_per_s: the board's F_CPU (its tick rate if its crystal were exact).
  explicit ClockSync(double nominal_ticks_per_s) : nominal_(nominal_ticks_per_s), rate_(nominal_ticks_per_s) {}

  // Called from: the player thread, for each clock reply. Host times in us (monotonic_us).
  // Returns false (and keeps nothing) when the board's time went back by more than
  // kResetJumpS twice in a row: its clock restarted (a reset), the caller resets.
  bool add(uint64_t send_us, uint64_t recv_us, uint32_t board_ticks);

  // Forgets every sample (the board restarted, or a new board); keeps the prior. Called from:
  // the player.
  void reset();
  // A rate known before the samples: the same crystal measured before (the board came back
  // after a reset, or the host remembers the board: player/board_memory.h). ticks_per_s and
  // its standard error in ppm. Until the samples span min_rate_span_s the fit takes it as its
  // rate; after, it weighs the two by their errors, the samples' error taken as at least
  // kPriorSpanErrors residuals over their span (a USB bridge's frames bias a short fit more
  // than its scatter shows), and drops the prior for good when they disagree by more than
  // kPriorRejectSigmas standard errors. Called from: the player, before the first sample of
  // the board it concerns.
  void set_prior(double ticks_per_s, double sigma_ppm);
  void clear_prior() { prior_sigma_ppm_ = 0; }
  bool has_prior() const { return prior_sigma_ppm_ > 0; }
  // Keeps the last `samples` only and fits a rate once they span min_rate_span_s (a board
  // simulated as fast as it runs changes speed: a short window follows it). Called from: the
  // player, before the first sample.
  // reset_jump_s: how far back the board's time must go to mean a new board (kResetJumpS);
  // point_samples: one point of the fit per this many samples (kPointSamples).
  void set_window(size_t samples, double min_rate_span_s, double reset_jump_s, size_t point_samples) {
    window_ = samples < 3 ? 3 : samples;
    min_rate_span_s_ = min_rate_span_s;
    reset_jump_s_ = reset_jump_s;
    point_samples_ = point_samples < 1 ? 1 : point_samples;
  }

  // Which way of the round trip the fit trusts. kSendSide: the request's (a direct link, where
  // a reply may wait for a bridge's whole batching time); ticks_at is then the board's time as
  // a request sent then reaches it. kRoundTrip: neither (the request waits in another
  // thread's queue for a time the link cannot tell): the quickest round trips, at their midpoints.
  enum class Way { kSendSide, kRoundTrip };
  // Called from: the player, before the first sample.
  void set_way(Way way) { way_ = way; }

  // True once a sample is in (before that, ticks_at is meaningless).
  bool ready() const { return !samples_.empty(); }
  size_t samples() const { return samples_.size(); }

  // The board's unwrapped tick count at a host time (us). Called from: the player.
  double ticks_at(double host_us) const { return offset_ticks_ + (host_us - origin_us_) * rate_ / 1e6; }
  // The board's unwrapped tick count in its newest reply: a time the board has surely reached
  // (the line's ticks_at may run ahead of a board that lags); before any reply, the line's
  // origin. Called from: the player.
  double newest_ticks() const { return samples_.empty() ? offset_ticks_ : samples_.back().ticks; }
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
  // The fit's typical error: the RMS of the kept points' residuals, us.
  double residual_us() const { return residual_us_; }
  // The rate's standard error, ppm (the residuals over the points' spread in time; 1e6 until
  // the rate is fitted).
  double rate_sigma_ppm() const { return rate_sigma_ppm_; }

  // One round trip as the fit keeps it.
  struct Sample {
    double host_us;  // host time the request was sent
    double ticks;    // unwrapped board ticks
    double rtt_us;
  };

 private:
  void fit();
  void settle_on_quickest();

  double nominal_, rate_;
  double origin_us_ = 0, offset_ticks_ = 0;  // the line passes through (origin_us_, offset_ticks_)
  double residual_us_ = 0;
  double rate_sigma_ppm_ = 1e6;
  double prior_rate_ = 0, prior_sigma_ppm_ = 0;  // set_prior; sigma 0: none
  std::deque<Sample> samples_;
  int outliers_ = 0;
  int off_line_ = 0;  // samples off the line in a row: + ahead of it, - behind
  bool has_rate_ = false;
  size_t window_ = kWindow;
  double min_rate_span_s_ = kMinRateSpanS;
  double reset_jump_s_ = kResetJumpS;
  size_t point_samples_ = kPointSamples;
  Way way_ = Way::kSendSide;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_CLOCK_SYNC_H

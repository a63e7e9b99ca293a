// timeline.h: the song player's timeline, song time -> board ticks: a line through an anchor at
// the board's tick rate, and how it takes a refined rate without a step (player/player.h).
//
// Song time s plays at board ticks anchor_ticks + (s - anchor_s) * rate, rate being the
// board's ticks per real second (its crystal's error included). When the clock fit refines
// the rate, follow() turns the line about a pivot, the song time of the last entry sent: that
// entry keeps its board time (no step in song time, no entry reordered), and every later song
// time moves to the refined rate. Called from: Player, its one thread; plain arithmetic.
#ifndef STEPCHOIR_HOST_PLAYER_TIMELINE_H
#define STEPCHOIR_HOST_PLAYER_TIMELINE_H

#include "player/clock_sync.h"

namespace stepchoir {

struct Timeline {
  // The fit's rate is taken when its standard error is at most this (ppm; 0.05 cent). A wider
  // one wanders by a few hundred ppm on a busy link.
  static constexpr double kRateSigmaPpm = 30.0;

  double anchor_s = 0, anchor_ticks = 0, rate = 0;  // rate: board ticks per real second

  // Sets the line: song time score_s at board ticks `ticks`, at `ticks_per_s`.
  void start(double score_s, double ticks, double ticks_per_s) {
    anchor_s = score_s;
    anchor_ticks = ticks;
    rate = ticks_per_s;
  }
  double ticks(double score_s) const { return anchor_ticks + (score_s - anchor_s) * rate; }
  double score(double board_ticks) const { return anchor_s + (board_ticks - anchor_ticks) / rate; }

  // Turns the line about pivot_s (it keeps its ticks) to `ticks_per_s`.
  void follow(double pivot_s, double ticks_per_s) { start(pivot_s, ticks(pivot_s), ticks_per_s); }

  // follow() with the fit's rate, if the fit has one within kRateSigmaPpm; true if it did.
  bool follow(double pivot_s, const ClockSync &fit) {
    if (!fit.has_rate() || fit.rate_sigma_ppm() > kRateSigmaPpm) return false;
    follow(pivot_s, fit.ticks_per_s());
    return true;
  }
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_TIMELINE_H

// start_gate.h: one song on several boards: each board's player syncs its own clock, then all
// take the same host time for the song's start, so that the boards' notes line up in real time.
#ifndef STEPCHOIR_HOST_PLAYER_START_GATE_H
#define STEPCHOIR_HOST_PLAYER_START_GATE_H

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

namespace stepchoir {

class StartGate {
 public:
  explicit StartGate(size_t players) : ready_us_(players, 0), left_(players, false) {}

  // Called from: each player's thread, once its board's clock is synced, again and again until
  // it returns the start (a player keeps syncing meanwhile). player: its index; now_us: host
  // time (monotonic_us). Returns 0 while some player is not ready, then the common start: the
  // time the last one was ready.
  uint64_t ready(size_t player, uint64_t now_us) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ready_us_[player] == 0) ready_us_[player] = now_us;
    uint64_t start = 0;
    for (size_t q = 0; q < ready_us_.size(); ++q) {
      if (left_[q]) continue;
      if (ready_us_[q] == 0) return 0;
      start = start > ready_us_[q] ? start : ready_us_[q];
    }
    return start;
  }

  // Called from: the command, once a player's run returned (a board that never synced must not
  // hold the others at the start).
  void leave(size_t player) {
    std::lock_guard<std::mutex> lock(mutex_);
    left_[player] = true;
  }

 private:
  std::mutex mutex_;
  std::vector<uint64_t> ready_us_;
  std::vector<bool> left_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_START_GATE_H

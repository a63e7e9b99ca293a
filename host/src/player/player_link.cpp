// player_link.cpp: the song player's side of its board's link: frames within the link budget,
// clock round trips and their replies, the first sync, reopening a lost board.
#include "player/player.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "live/midi_in.h"

namespace stepchoir {

namespace {

// In board-time mode, where the board runs faster than real time, clock round trips this
// often (us) while syncing.
constexpr uint64_t kBoardTimeSyncEveryUs = 1000;
// Before the first note the sync waits up to this long (s) more for the rate to be within
// kRateSigmaPpm: a board met for the first time behind a USB bridge (a remembered one has its
// rate at once; bench/results/clock-links.md).
constexpr double kSyncLongerS = 2.0;
// A USB full-speed frame (us): a bridge may hold host bytes this long.
constexpr double kUsbFrameUs = 1000;

}  // namespace

// Called from: everything that writes. One frame; counts it against the link budget (waiting
// for it when the budget is spent). sent_us, when given, gets the time just before the write, or
// when a link that queues (jam) handed the frame to the OS (0 when that did not happen in time).
// False when the link failed.
bool Player::send_payload(const std::vector<uint8_t> &payload, uint64_t *sent_us) {
  if (!board_) {  // closed for a reopen that has not succeeded yet
    board_lost_ = true;
    return false;
  }
  const std::vector<uint8_t> wire = frame(payload);
  budget_.refill(monotonic_us());
  while (!budget_.can_send()) {
    std::this_thread::sleep_for(std::chrono::microseconds(budget_.wait_us()));
    budget_.refill(monotonic_us());
  }
  bool ok = false;
  if (sent_us) *sent_us = monotonic_us();
  try {
    ok = board_->link().write(wire.data(), wire.size());
  } catch (const std::exception &) {
  }
  if (!ok) {
    board_lost_ = true;
    return false;
  }
  budget_.spend(wire.size());
  if (sent_us && board_->link().queues_writes())  // it knows when the frame truly left (jam)
    *sent_us = board_->link().written_at_us();  // 0: not in time, the send time is unknown
  // The line to the board is busy with this frame's bits, after whatever it still carried,
  // and the bridge may hold the last of them for a USB frame.
  const double now = static_cast<double>(monotonic_us());
  line_free_us_ = std::max(now, line_free_us_) + wire.size() * 10.0 * 1e6 / sc::kBaud + kUsbFrameUs;
  ++stats_.frames_sent;
  return true;
}

// Called from: the loop and sync_clock. One clock request, its send time kept by sequence.
// The next one is due a little later each time, by a fraction of a USB frame that never
// repeats (golden-ratio steps): requests sent on a fixed grid of whole milliseconds would
// meet the host's 1 ms USB frames at one phase only, and the way out would read as constant.
void Player::send_clock_request(uint64_t now_us) {
  ++clock_seq_;
  dither_ = std::fmod(dither_ + 0.6180339887, 1.0);
  last_clock_us_ = now_us + static_cast<uint64_t>(dither_ * kUsbFrameUs);
  clock_sent_us_[clock_seq_] = 0;
  send_payload({sc::kMsgClockReq, clock_seq_}, &clock_sent_us_[clock_seq_]);
}

// Called from: the loop. Reads what the board sent within timeout_ms and takes in clock
// replies and errors. False when the link failed.
bool Player::read_replies(int timeout_ms) {
  uint8_t buf[512];
  long n = -1;
  try {
    n = board_->link().read(buf, sizeof buf, timeout_ms);
  } catch (const std::exception &) {
  }
  const uint64_t now = monotonic_us();
  // Since the last read ended: this read's wait, and any time the player was held up (its loop,
  // or the process stopped in or out of the read), which is not the board's silence.
  const uint64_t waited = uint64_t(timeout_ms) * 1000;
  if (heard_us_ && last_read_us_ && now > last_read_us_ + waited + kListenGapUs)
    heard_us_ = std::min(now, heard_us_ + (now - last_read_us_ - waited));
  last_read_us_ = now;
  if (n < 0) {
    board_lost_ = true;
    return false;
  }
  for (long i = 0; i < n; ++i) {
    if (decoder_.push(buf[i]) != sc::kFrameOk) continue;
    if (heard_us_) heard_us_ = now;
    const uint8_t *p = decoder_.payload();
    const uint8_t len = decoder_.payload_len();
    if (p[0] == sc::kMsgClock && len >= 6) {
      const uint64_t sent = clock_sent_us_[p[1]];
      if (sent == 0 || now - sent > 1000000) continue;  // not ours, or from long ago
      clock_sent_us_[p[1]] = 0;
      if (clock_log_) std::fprintf(clock_log_, "%llu,%llu,%u\n", static_cast<unsigned long long>(sent),
                                   static_cast<unsigned long long>(now), sc::get_u32(&p[2]));
      if (!sync_.add(sent, now, sc::get_u32(&p[2]))) {
        board_restarted_ = true;  // its clock started again: a reset
        continue;
      }
      ++stats_.clock_samples;
      stats_.ppm = sync_.ppm();
      stats_.residual_us = sync_.residual_us();
      follow_rate();
    } else if (p[0] == sc::kMsgStatus) {
      take_status(p, len);
    } else if (p[0] == sc::kMsgError && len >= 4) {
      stats_.last_error = p[1];
      if (p[1] == sc::kErrLate)
        ++stats_.late_reported;
      else if (p[1] == sc::kErrQueueFull)
        ++stats_.queue_full;
      else if (p[1] != sc::kErrWatchdog)
        ++stats_.other_errors;
    }
  }
  return true;
}

// Called from: read_replies. A status reply into the stats (a malformed one is left out: the
// board's counters say so at the end).
void Player::take_status(const uint8_t *p, size_t len) {
  Status st;
  try {
    st = parse_status(p, len);
  } catch (const std::exception &) {
    return;
  }
  for (size_t m = 0; m < st.motors.size() && m < sc::kMaxMotors; ++m) {
    stats_.motor_position[m] = st.motors[m].position_steps;
    stats_.motor_reversals[m] = st.motors[m].reversals;
    stats_.motor_flags[m] = st.motors[m].flags;
  }
  stats_.board_reversals = st.head.reversals;
  stats_.has_status = true;
}

// Called from: run and reconnect. Clock round trips every kSyncEveryUs for `seconds` (at
// least 20), so the first notes already have a fitted offset, and, with need_rate, until the
// fit has a rate within kRateSigmaPpm (a second of samples on a quiet link, a few behind a
// USB bridge; kSyncLongerS more at most; any rate without refine_rate, or under a song clock,
// whose Start may come at once and whose timeline takes the fit as it is). Nothing else of the song's is on the link
// meanwhile: the many round trips give each of the fit's points its quickest way out.
bool Player::sync_clock(double seconds, bool need_rate, const std::atomic<bool> &stop) {
  const uint64_t start = monotonic_us();
  const uint64_t step_us = opt_.board_time ? kBoardTimeSyncEveryUs : kSyncEveryUs;
  const uint64_t first = stats_.clock_samples;
  for (int i = 0; !stop.load(); ++i) {
    const uint64_t now = monotonic_us();
    const bool rate_ok = sync_.has_rate() && (!opt_.refine_rate || opt_.song_clock ||
                                              sync_.rate_sigma_ppm() <= kRateSigmaPpm ||
                                              now - start >= (seconds + kSyncLongerS) * 1e6);
    if (now - start >= seconds * 1e6 && stats_.clock_samples - first >= 20 &&
        (!need_rate || opt_.board_time || rate_ok))
      return true;
    if (now - start > (seconds + kSyncLongerS + 5) * 1e6) {
      error_ = board_->link().name() + ": the board does not answer clock requests";
      return false;
    }
    send_clock_request(now);
    const uint64_t until = last_clock_us_ + step_us;
    while (monotonic_us() < until)
      if (!read_replies(1)) return false;
    (void)i;
  }
  return false;
}

// Called from: run when the board was lost (link failed) or restarted (its clock began
// again), before the song (its first sync) or during it. Opens it again (retrying up to
// reconnect_s), says hello and sets the board up again (on_reopen); the clock fit starts again,
// the rate measured so far its prior.
// False when the board does not come back.
bool Player::reopen(const std::atomic<bool> &stop) {
  const uint64_t start = monotonic_us();
  for (;;) {
    if (stop.load()) return false;
    try {
      if (board_lost_) {
        if (!opener_) throw std::runtime_error("cannot be opened again");
        // A silent board's port is closed first: on a real one DTR drops, so the open resets it.
        if (board_silent_) board_.reset();
        board_ = std::make_unique<Board>(opener_());
      }
      // A silent board is listened to in silence first: a Mega's bootloader, held by the bytes
      // that kept coming, starts the firmware only after 5 s without one.
      const Caps caps = board_silent_                     ? board_->greet(Board::kQuietWaitMs)
                        : board_lost_ && opt_.open_resets ? board_->greet()
                                                          : board_->hello();
      if (caps.motor_count != caps_.motor_count || caps.f_cpu_hz != caps_.f_cpu_hz)
        throw std::runtime_error("a different board answered");
      if (opt_.on_reopen) opt_.on_reopen(*board_, caps);
      break;
    } catch (const std::exception &e) {
      stats_.reconnecting = true;
      // The song goes on meanwhile (its place on the clock as last fitted); the caller's
      // console and keys stay alive.
      if (playing_) report(score_now(monotonic_us()), false);
      if (monotonic_us() - start > opt_.reconnect_s * 1e6) {
        char within[32];
        std::snprintf(within, sizeof within, "%g s", opt_.reconnect_s);
        error_ = "the board was lost and did not come back within " + std::string(within) + " (" + e.what() + ")";
        return false;
      }
      board_lost_ = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  board_lost_ = board_restarted_ = board_silent_ = false;
  last_read_us_ = monotonic_us();
  if (heard_us_) heard_us_ = last_read_us_;
  stats_.reconnecting = false;
  decoder_ = sc::FrameDecoder();
  // The entries sent on the old board's clock since the restart, before the player saw it,
  // would wait in the queue for times that mean nothing on the new clock, holding up the
  // song's entries behind them; one of them past its time would sound at once.
  send_payload(silence_payload(opt_.motors));
  send_payload(watchdog_payload(sc::kWatchdogDefaultMs));
  // The same board back: the same crystal. The rate measured so far is the new fit's prior,
  // so the notes after the reconnect are in tune before the new samples span a second.
  if (sync_.has_rate()) sync_.set_prior(sync_.ticks_per_s(), sync_.rate_sigma_ppm());
  sync_.reset();
  queued_ticks_.clear();
  ++stats_.reconnects;
  return true;
}

}  // namespace stepchoir

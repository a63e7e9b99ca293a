// player.cpp: the song player's loop: the timeline, `at` frames ahead of time, pause, loop,
// reconnecting (its link side: player_link.cpp).
#include "player/player.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <thread>

#include "core/pitch.h"
#include "live/midi_in.h"

namespace stepchoir {

namespace {

// Entries the host leaves free in the board's queue.
constexpr size_t kQueueSpare = 2;
// An entry is taken as gone from the board's queue once a clock reply says the board's time
// passed it by this much (the board's main loop lets it go a little before its time). The
// host's own estimate of the board's time is not enough: a board that lags (a simulation
// slowed by the machine) would still hold entries the estimate says are gone.
constexpr double kQueueFreeAfterS = 0.001;
// The song is over once a clock reply says the board passed its end; if the board stops
// replying, this long after the host's estimate says so.
constexpr double kEndWaitS = 2.0;
// Board-time mode: clock round trips this often (the simulated board's speed changes), and
// the fit's window (samples) and shortest span for a rate.
constexpr double kBoardTimeClockEveryS = 0.005;
constexpr size_t kBoardTimeWindow = 16;

}  // namespace

Player::Player(std::unique_ptr<Board> board, const Caps &caps, std::vector<PlanEvent> events, double duration_s,
               const PlayerOptions &options, LinkOpener opener)
    : board_(std::move(board)),
      caps_(caps),
      events_(std::move(events)),
      duration_s_(duration_s),
      opt_(options),
      opener_(std::move(opener)),
      sync_(caps.f_cpu_hz) {
  if (!board_) throw std::invalid_argument("player: no board");
  if (opt_.motors.empty())
    for (uint8_t m = 0; m < caps_.motor_count; ++m) opt_.motors.push_back(m);
  for (const PlanEvent &e : events_)
    if (e.motor >= opt_.motors.size() || opt_.motors[e.motor] >= caps_.motor_count)
      throw std::invalid_argument("player: the plan uses motor " + std::to_string(e.motor) + ", the board has " +
                                  std::to_string(caps_.motor_count));
  // STEPCHOIR_PLAYER_CLOCK_LOG=FILE: every clock round trip (send us, receive us, board ticks),
  // for studying the clock fit.
  if (const char *log = std::getenv("STEPCHOIR_PLAYER_CLOCK_LOG")) clock_log_ = std::fopen(log, "w");
  if (opt_.loop && !(duration_s_ > 0)) throw std::invalid_argument("player: an empty song cannot loop");
  // A board simulated as fast as it runs changes speed all the time, and is this program's
  // own child: no sample there means a reset.
  if (opt_.board_time) sync_.set_window(kBoardTimeWindow, 0.02, 1e9, 1);
  // Sharing the board (jam), the requests wait in the live path's queue before they go out:
  // the send side holds when that link tells when each truly left (JamLink does).
  if (!opt_.exclusive && !board_->link().queues_writes()) sync_.set_way(ClockSync::Way::kRoundTrip);
  // A board met before: its remembered crystal is the clock fit's prior, so the first note is
  // in tune although the first second's samples cannot tell the rate that well.
  if (opt_.crystal_ppm && !opt_.board_time && opt_.auto_tune)
    sync_.set_prior(caps_.f_cpu_hz * (1 + *opt_.crystal_ppm / 1e6), opt_.crystal_sigma_ppm);
}

double Player::event_ticks(double score_s) const {
  if (opt_.song_clock) return std::max(sent_ticks_, sync_.ticks_at(opt_.song_clock->host_us(score_s)));
  return line_.ticks(score_s);
}

double Player::score_now(uint64_t now_us) const {
  if (opt_.song_clock) return opt_.song_clock->locked() ? opt_.song_clock->score_at(static_cast<double>(now_us)) : sent_score_;
  return line_.score(sync_.ticks_at(static_cast<double>(now_us)));
}

// Called from: run, each pass, with a song clock. A start (or continue) silences what the song
// played and, once the clock's grid is known, restores what sounds at its position and plays
// on from there; a stop silences the song. True while the song plays.
bool Player::follow_clock() {
  SongClock &c = *opt_.song_clock;
  c.poll();
  if (c.starts() != clock_starts_) {
    clock_starts_ = c.starts();
    if (clock_playing_) silence();
    clock_playing_ = false;
    clock_pending_ = true;
  }
  if (clock_pending_ && c.running() && c.locked()) {
    clock_pending_ = false;
    sent_ticks_ = 0;
    clock_playing_ = restore_at(c.start_score_s());
  } else if (clock_playing_ && !c.running()) {
    silence();
    clock_playing_ = false;
  }
  return clock_playing_;
}

// Called from: run (start, resume) and reconnect. Song time score_s plays one lead after
// now_us, at the fit's rate (nominal in board-time mode or without auto-tune; the rate
// measured so far when the fit has none yet, as after a reconnect: the same crystal).
void Player::anchor(double score_s, uint64_t now_us) {
  double rate = line_.rate;
  if (opt_.board_time || !opt_.auto_tune)
    rate = caps_.f_cpu_hz;
  else if (sync_.has_rate() || rate == 0)
    rate = sync_.ticks_per_s();
  line_.start(score_s, sync_.ticks_at(static_cast<double>(now_us)) + opt_.lead_s * rate, rate);
  stats_.rate_ppm = (rate / caps_.f_cpu_hz - 1.0) * 1e6;
}

// Called from: read_replies, after each clock sample. With auto-tune in real time, while the
// fit's rate is within kRateSigmaPpm (a wider one wanders by a few hundred ppm on a busy link;
// the rate the timeline has stays meanwhile: decision 023), the timeline and the pitches take it
// from the last entry sent on: that entry keeps its board time (no step in song time, no entry
// reordered), and the notes not yet sent get their times and periods at the refined rate (a
// held note keeps its period).
void Player::follow_rate() {
  if (!playing_ || opt_.board_time || !opt_.auto_tune || !opt_.refine_rate || opt_.song_clock) return;
  if (line_.follow(sent_score_, sync_)) stats_.rate_ppm = (line_.rate / caps_.f_cpu_hz - 1.0) * 1e6;
}

// The period of a pitch on this board: from its measured clock rate (auto-tune), so the note
// sounds right in real time even when its crystal is off.
uint32_t Player::period_for(double pitch) const {
  const double hz = note_hz(pitch, opt_.a4_hz);
  uint32_t period = hz_to_period_q8(hz, line_.rate);
  if (period != sc::kPeriodSilent && period < sc::kPeriodQ8Min) period = sc::kPeriodQ8Min;
  return period;
}

// Called from: the loop. Sends every event due within the lead, as far as the board's queue
// has room: one `at` frame per group of events at the same time. False when the link failed.
bool Player::send_due(uint64_t now_us) {
  const double now_ticks = sync_.ticks_at(static_cast<double>(now_us));
  const double reached = sync_.newest_ticks() - kQueueFreeAfterS * caps_.f_cpu_hz;
  while (!queued_ticks_.empty() && queued_ticks_.front() < reached) queued_ticks_.pop_front();
  const double lead_ticks = opt_.lead_s * caps_.f_cpu_hz;
  const size_t capacity = caps_.queue_size > kQueueSpare ? caps_.queue_size - kQueueSpare : 1;
  const size_t per_frame = (sc::kMaxPayload - 5) / sc::kSetPeriodBytes;
  while (cursor_ < events_.size()) {
    const double score = loop_ * duration_s_ + events_[cursor_].time_s;
    const double ticks = event_ticks(score);
    if (ticks - now_ticks > lead_ticks) break;
    // The group: events at the same time (one frame holds per_frame of them).
    size_t end = cursor_;
    while (end < events_.size() && end - cursor_ < per_frame && events_[end].time_s == events_[cursor_].time_s) ++end;
    if (queued_ticks_.size() + (end - cursor_) > capacity) break;
    std::vector<sc::PeriodEntry> entries;
    for (size_t i = cursor_; i < end; ++i)
      entries.push_back({opt_.motors[events_[i].motor], events_[i].silent ? sc::kPeriodSilent : period_for(events_[i].pitch)});
    if (!send_at(ticks, entries)) return false;
    sent_score_ = score;
    stats_.min_lead_ms = std::min(stats_.min_lead_ms, (ticks - now_ticks) / caps_.f_cpu_hz * 1e3);
    cursor_ = end;
    if (cursor_ == events_.size() && opt_.loop) {
      cursor_ = 0;
      ++loop_;
    }
  }
  return true;
}

// Called from: resume and reconnect. Every motor that should sound at score_s starts at the
// board time of score_s; the events from there on follow.
bool Player::restore_at(double score_s) {
  const double in_loop = opt_.loop ? std::fmod(std::max(score_s, 0.0), duration_s_) : score_s;
  loop_ = opt_.loop ? static_cast<unsigned>(std::floor(std::max(score_s, 0.0) / duration_s_)) : 0;
  std::vector<double> pitch(opt_.motors.size(), -1);
  cursor_ = 0;
  while (cursor_ < events_.size() && events_[cursor_].time_s <= in_loop) {
    pitch[events_[cursor_].motor] = events_[cursor_].silent ? -1 : events_[cursor_].pitch;
    ++cursor_;
  }
  std::vector<sc::PeriodEntry> entries;
  for (size_t m = 0; m < pitch.size(); ++m)
    if (pitch[m] >= 0) entries.push_back({opt_.motors[m], period_for(pitch[m])});
  sent_score_ = score_s;
  return entries.empty() || send_at(event_ticks(score_s), entries);
}

// Called from: send_due, restore_at, silence. One `at` frame for entries at board ticks
// (unwrapped), counted as held in the board's queue until their time. False when the link failed.
bool Player::send_at(double ticks, const std::vector<sc::PeriodEntry> &entries) {
  const uint32_t at = static_cast<uint32_t>(static_cast<uint64_t>(std::llround(ticks)));
  if (!send_payload(at_payload(at, entries))) return false;
  sent_ticks_ = ticks;
  stats_.entries_sent += entries.size();
  queued_ticks_.insert(queued_ticks_.end(), entries.size(), ticks);
  return true;
}

// Called from: run, at the end, on pause and on stop. Every motor of the song silent now and
// its queued entries dropped: with the board to itself, by stop-all (the drivers off as well);
// sharing it (jam, a setlist beside live), by silence for the song's motors, since stop-all
// would silence the keyboard's motors too.
void Player::silence() {
  send_payload(opt_.exclusive ? std::vector<uint8_t>{sc::kMsgStopAll} : silence_payload(opt_.motors));
  queued_ticks_.clear();
}

// Called from: run when the board was lost or restarted mid-song. Opens it again, syncs the
// clock and carries on where the song is now: what should sound is restored at once. False
// when it cannot.
bool Player::reconnect(const std::atomic<bool> &stop) {
  const uint64_t start = monotonic_us();
  const double lost_at_s = score_now(start);  // the old board's clock, as last fitted
  if (!reopen(stop) || !sync_clock(0.2, false, stop)) return false;
  const uint64_t now = monotonic_us();
  const double at_s = lost_at_s + (now - start) / 1e6 + opt_.lead_s;  // the song went on meanwhile
  // The new fit sets the offset; its rate is the prior until its samples say more.
  anchor(at_s, now);
  return restore_at(at_s);
}

// Called from: run and reopen. Tells the caller where the song is: pos, song time with the
// loops played counted in (at_end: the end, position_s the song's duration).
void Player::report(double pos, bool paused, bool at_end) {
  if (!on_progress_ || !*on_progress_) return;
  PlayerProgress p;
  p.duration_s = duration_s_;
  p.stats = &stats_;
  p.position_s = at_end     ? duration_s_
                 : opt_.loop ? std::fmod(std::max(pos, 0.0), duration_s_)
                             : std::max(0.0, std::min(pos, duration_s_));
  p.loop = opt_.loop ? static_cast<unsigned>(std::max(pos, 0.0) / duration_s_) : 0;
  p.paused = paused;
  (*on_progress_)(p);
}

bool Player::run(const std::atomic<bool> &stop, const std::atomic<bool> &pause,
                 const std::function<void(const PlayerProgress &)> &on_progress) {
  on_progress_ = &on_progress;
  struct Forget {  // on_progress lives only as long as this call
    const std::function<void(const PlayerProgress &)> **p;
    ~Forget() { *p = nullptr; }
  } forget{&on_progress_};
  // The motors stop by themselves if this program dies. Not in board-time mode: the simulated
  // board runs several times faster than real time, so a host stalled for a moment would
  // starve its watchdog; it is this program's own child and ends with it anyway.
  send_payload(watchdog_payload(opt_.board_time ? 0 : sc::kWatchdogDefaultMs));
  // The board's counters from here on, so that the report at the end is this song's (a board
  // that waited for its host has a watchdog trip on record).
  if (opt_.exclusive) send_payload({sc::kMsgResetCounters});
  // A board lost (or reset) during its first sync is opened again and synced from the start.
  while (!sync_clock(opt_.board_time ? 0.02 : opt_.sync_s, true, stop)) {
    if (stop.load() || !(board_lost_ || board_restarted_) || !reopen(stop)) {
      silence();
      return stop.load();
    }
  }
  uint64_t begin = monotonic_us();
  // Several boards: one start for all, once every board is synced; this board's clock is
  // sampled meanwhile.
  while (opt_.start_gate && !board_lost_) {
    if (stop.load()) {
      silence();
      return true;
    }
    const uint64_t now = monotonic_us();
    if (const uint64_t at = opt_.start_gate(now)) {
      begin = at;
      break;
    }
    if (now >= last_clock_us_ + kSyncEveryUs) send_clock_request(now);
    read_replies(1);
  }
  anchor(0.0, begin);
  sent_score_ = 0;
  playing_ = true;
  last_read_us_ = monotonic_us();
  if (opt_.exclusive && !opt_.board_time) heard_us_ = last_read_us_;
  const double clock_every_us = (opt_.board_time ? kBoardTimeClockEveryS : opt_.clock_every_s) * 1e6;
  bool paused = false;
  double paused_at = 0;
  uint64_t last_progress = 0;
  double last_pos = 0;  // the last report's, for the one at the end
  bool last_paused = false;
  for (;;) {
    if (stop.load()) break;
    if ((board_lost_ || board_restarted_) && !reconnect(stop)) {
      silence();
      return stop.load();
    }
    uint64_t now = monotonic_us();
    if (!opt_.song_clock && pause.load() != paused) {
      paused = !paused;
      if (paused) {
        paused_at = score_now(now);
        silence();
      } else {  // carry on where it paused, one lead from now
        anchor(paused_at, now);
        if (!restore_at(paused_at)) continue;
      }
    }
    // A clock request only on an idle line: one queued behind note frames reaches the board
    // late, and its sample would read the board's clock as ahead.
    if (now >= last_clock_us_ + clock_every_us && static_cast<double>(now) >= line_free_us_) send_clock_request(now);
    // The carriages and endstop hits (the console's), on an idle line too; a shared board's
    // live writer asks for them itself.
    if (opt_.exclusive && !opt_.board_time && now >= last_status_us_ + kStatusEveryUs &&
        static_cast<double>(now) >= line_free_us_) {
      last_status_us_ = now;
      send_payload({sc::kMsgStatusReq});
    }
    const bool on_clock = !opt_.song_clock || follow_clock();
    if (!paused && on_clock && !send_due(now)) continue;
    if (!read_replies(1)) continue;
    now = monotonic_us();
    // Asked for its clock and status several times a second, the board answers; one that sent
    // nothing while this player listened for so long has stopped (a Mega reset with its link
    // up, held in its bootloader by these very bytes) and is opened again after a silence. A
    // shared board's (jam, a setlist song) is live's to watch.
    if (heard_us_ && now > heard_us_ + uint64_t(Board::kSilentMs) * 1000) {
      board_silent_ = board_lost_ = true;
      continue;
    }
    const double pos = paused ? paused_at : score_now(now);
    if (now - last_progress >= 100000) {
      last_progress = now;
      last_pos = pos;
      last_paused = paused;
      report(pos, paused);
    }
    // The end: every event sent and the last one played.
    if (!opt_.loop && cursor_ == events_.size() && pos > duration_s_ &&
        (sync_.newest_ticks() > event_ticks(duration_s_) || pos > duration_s_ + kEndWaitS))
      break;
  }
  // Let replies to the last entries come in, then silence everything.
  read_replies(5);
  silence();
  read_replies(20);
  try {
    if (const auto st = board_->status(500)) {
      stats_.board_frames_bad = st->head.frames_bad;
      stats_.board_overruns = st->head.uart_overruns;
      stats_.board_last_error = st->head.last_error;
    }
  } catch (const std::exception &) {
  }
  report(last_pos, last_paused, true);
  return true;
}

}  // namespace stepchoir

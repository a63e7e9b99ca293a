// player.h: plays a planned song on one board from the board's own queue: clock sync,
// timestamped `at` frames sent ahead, pitch corrected for the board's measured clock rate,
// pause/resume, loop, and carrying on after a board reset or a replugged cable.
//
// Timeline: the board's clock is the song's clock. Song time s plays at board ticks
// anchor_ticks + (s - anchor_s) * rate, where rate is the board's tick rate per real second
// as the clock fit measures it (its crystal's error included): the notes keep exact time to
// one another on the board's timer whatever the host or the link do, and the song runs at its
// real tempo. The fit keeps refining the rate while the song plays (round trips through a USB
// bridge are noisy: the first second's rate may be a hundred ppm or more off). While the
// fit's rate is within 30 ppm the timeline follows it phase-continuously (player/timeline.h;
// not under a song clock, whose timeline is the fit itself): the anchor moves to the last
// entry sent, which keeps its board time, so song time never steps, and the notes not yet sent
// take the refined rate for their times and periods (follow_rate).
// A held note keeps its period. Each entry goes out lead_s before its time, as far as the
// board's queue (Caps::queue_size entries) has room. The host's scheduling jitter only moves
// when a frame is sent, never when a note starts. In board-time mode (render, a virtual board
// simulated as fast as it runs) the rate is the nominal F_CPU.
//
// Called from: the play, render and jam commands; one thread (the caller's) runs everything.
// It reads replies with short timeouts between sends; nothing here is on a real-time path
// (the board's queue is the real-time part).
#ifndef STEPCHOIR_HOST_PLAYER_PLAYER_H
#define STEPCHOIR_HOST_PLAYER_PLAYER_H

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "board/board.h"
#include "live/session.h"
#include "player/clock_sync.h"
#include "player/plan.h"
#include "player/timeline.h"

namespace stepchoir {

// A clock the song follows instead of its own time (jam --midi-clock: player/midi_clock.h).
// Called from: the player's thread only, each pass of its loop.
class SongClock {
 public:
  virtual ~SongClock() = default;
  virtual void poll() = 0;                            // takes what came since the last call
  virtual uint64_t starts() const = 0;                // starts (and continues) so far
  virtual bool running() const = 0;                   // started and not stopped
  virtual bool locked() const = 0;                    // its grid is known: host_us answers
  virtual double start_score_s() const = 0;           // the song time the last start began at
  virtual double host_us(double score_s) const = 0;   // when a song time plays (monotonic_us)
  virtual double score_at(double host_us) const = 0;  // the song time at a host time
};

struct PlayerOptions {
  bool board_time = false;       // render: the board's ticks are the timeline
  double lead_s = 0.3;           // entries go to the board this long before their time
  double sync_s = 1.0;           // clock round trips before the first note (real time)
  double clock_every_s = 0.01;   // a clock round trip this often while playing (7 bytes)
  bool loop = false;             // start again at the end, seamlessly
  double a4_hz = kA4Hz;
  bool auto_tune = true;         // periods from the measured clock rate (else F_CPU)
  double reconnect_s = 30;       // a lost board is retried this long (0: give up at once)
  bool open_resets = true;       // the opener's open resets the board (a port): reopen waits out
                                 // its bootloader (Board::greet); jam: false, the live path
                                 // reopened the port and waited: reopen asks (Board::hello)
  std::vector<uint8_t> motors;   // plan motor -> board motor (empty: the same index)
  bool exclusive = true;         // the board is the song's alone (jam: false, see silence())
  // Before the first note, wait (up to 2 s more) for the clock fit's rate to be within 30 ppm,
  // and follow the fit as the song plays (decision 023). false: the song starts after sync_s
  // with the rate it has then and keeps it (live's setlist: its song starts at the pedal).
  bool refine_rate = true;
  // The board's crystal error and its standard error (ppm) as remembered from an earlier song
  // (config/board_memory.h); the clock fit's prior. nullopt: a board met for the first time.
  std::optional<double> crystal_ppm;
  double crystal_sigma_ppm = 0;
  // Several boards in one song (player/start_gate.h): called once this board's clock is synced
  // with the host time (us), and again every millisecond while it returns 0; then it returns
  // the host time that every board takes for the song's start. Empty: this board alone.
  std::function<uint64_t(uint64_t now_us)> start_gate;
  // Called from: reopen, on the board greeted again after a loss or a reset, before the song
  // goes on: what the caller set up on it before the first note (the rig file's motor
  // configuration), which a restarted board has forgotten. Throws when the board refuses it.
  std::function<void(Board &, const Caps &)> on_reopen;
  // Not null: the song follows this clock (it starts, stops and continues it; no loop, no
  // pause, the timeline's own rate unused). Owned by the caller, who keeps it alive.
  SongClock *song_clock = nullptr;
};

// What the player did, for the progress line, the final report and tests.
struct PlayerStats {
  uint64_t entries_sent = 0, frames_sent = 0;
  uint64_t late_reported = 0;      // kErrLate replies: an entry came after its time
  uint64_t queue_full = 0;         // kErrQueueFull replies
  uint64_t other_errors = 0;
  uint8_t last_error = 0;
  uint64_t clock_samples = 0;
  uint64_t reconnects = 0;         // board lost (cable, reset) and found again
  bool reconnecting = false;       // the board is lost now: its port is being opened again
  double min_lead_ms = 1e9;        // the least time ahead of its start an entry was sent
  double ppm = 0;                  // the board's crystal error, as the clock fit has it now
  double rate_ppm = 0;             // the crystal error the timeline and the pitches use now
  double residual_us = 0;          // the clock fit's RMS error
  // The board's own counters at the end (status reply; -1: none came).
  long board_frames_bad = -1, board_overruns = -1;
  uint8_t board_last_error = 0;
  // Its latest status reply while the song plays (play only; every kStatusEveryUs): each board
  // motor's carriage position (steps), endstop hits since the song began and flags
  // (sc::kMotorEndstopFault ...); the board's hits in all.
  bool has_status = false;
  int32_t motor_position[sc::kMaxMotors] = {};
  uint16_t motor_reversals[sc::kMaxMotors] = {};
  uint8_t motor_flags[sc::kMaxMotors] = {};
  uint16_t board_reversals = 0;
};

struct PlayerProgress {
  double position_s = 0, duration_s = 0;
  unsigned loop = 0;
  bool paused = false;
  const PlayerStats *stats = nullptr;
};

// Opens the board again after it was lost (the same path); throws when it is not there yet.
using LinkOpener = std::function<std::unique_ptr<Link>()>;

class Player {
 public:
  // events: plan_events() of the plan; duration_s: the plan's. The board must have said hello
  // (caps). opener may be empty (no reconnection).
  Player(std::unique_ptr<Board> board, const Caps &caps, std::vector<PlanEvent> events, double duration_s,
         const PlayerOptions &options, LinkOpener opener = {});

  // Plays to the end (or forever with loop) unless *stop is set; *pause pauses (every motor
  // silent, the board's queue emptied) and resumes where it was. on_progress is called about
  // every 100 ms, also while a lost board is being opened again (stats.reconnecting; the
  // greeting of a board that came back holds it up to about 2.5 s, of one that went silent up to
  // Board::kQuietWaitMs and a hello). Leaves every motor silent
  // and the drivers off. Returns false when the board was lost for good (the reason in
  // error()); true when *stop ended it, also while the board was lost.
  bool run(const std::atomic<bool> &stop, const std::atomic<bool> &pause,
           const std::function<void(const PlayerProgress &)> &on_progress);

  const PlayerStats &stats() const { return stats_; }
  const std::string &error() const { return error_; }
  const ClockSync &clock() const { return sync_; }
  ~Player() {
    if (clock_log_) std::fclose(clock_log_);
  }
  Player(const Player &) = delete;
  Player &operator=(const Player &) = delete;

 private:
  // Clock round trips this often (us) while syncing before the first note and while waiting
  // for the other boards (7 bytes each, under 1 % of the link).
  static constexpr uint64_t kSyncEveryUs = 10000;
  // The clock fit's rate is taken when its standard error is at most this (ppm; 0.05 cent).
  static constexpr double kRateSigmaPpm = Timeline::kRateSigmaPpm;
  // Playing on its own board, a status request this often (us): the console's carriages and
  // endstop hits.
  static constexpr uint64_t kStatusEveryUs = 250000;
  // A pause between two reads longer than this is the loop's, not the board's silence.
  static constexpr uint64_t kListenGapUs = 100000;
  bool send_payload(const std::vector<uint8_t> &payload, uint64_t *sent_us = nullptr);
  void send_clock_request(uint64_t now_us);
  bool read_replies(int timeout_ms);
  void take_status(const uint8_t *p, size_t len);
  bool sync_clock(double seconds, bool need_rate, const std::atomic<bool> &stop);
  double event_ticks(double score_s) const;  // unwrapped board ticks of a song time
  double score_now(uint64_t now_us) const;   // the song time now on the board (may be before 0)
  uint32_t period_for(double pitch) const;
  bool send_due(uint64_t now_us);
  bool send_at(double ticks, const std::vector<sc::PeriodEntry> &entries);
  bool restore_at(double score_s);           // entries for what sounds at score_s, at its time
  bool reopen(const std::atomic<bool> &stop);
  void report(double pos, bool paused, bool at_end = false);  // on_progress_: where the song is
  bool reconnect(const std::atomic<bool> &stop);
  void silence();

  std::unique_ptr<Board> board_;
  Caps caps_;
  std::vector<PlanEvent> events_;
  double duration_s_;
  PlayerOptions opt_;
  LinkOpener opener_;
  ClockSync sync_;
  PlayerStats stats_;
  std::string error_;
  sc::FrameDecoder decoder_;
  LinkBudget budget_;
  uint64_t clock_sent_us_[256] = {};
  uint8_t clock_seq_ = 0;
  uint64_t last_clock_us_ = 0;  // when the last clock request went out, plus its dither
  uint64_t last_status_us_ = 0; // when the last status request went out
  double dither_ = 0;           // fraction of a USB frame added to the next request's time
  double line_free_us_ = 0;  // host time (us) the line to the board has carried what was written
  bool board_lost_ = false, board_restarted_ = false;
  // The board sent nothing for Board::kSilentMs while the song played (play: it is asked for
  // its clock and status several times a second): it is opened again after a silence.
  bool board_silent_ = false;
  // When the board last sent a whole frame (monotonic_us), once playing; moved on by the time
  // this player did not listen (its loop held up elsewhere), which is not the board's silence.
  uint64_t heard_us_ = 0;
  uint64_t last_read_us_ = 0;  // when read_replies last returned
  // Song time s (in loop k: k * duration + s) -> board ticks (see the top; player/timeline.h).
  Timeline line_;
  void anchor(double score_s, uint64_t now_us);  // sets the timeline: score_s one lead after now
  void follow_rate();                         // the timeline takes the fit's refined rate
  double sent_score_ = 0;   // song time of the last entry sent (the pivot for follow_rate)
  double sent_ticks_ = 0;   // its board ticks: a clock's refit never sends an entry before it
  bool follow_clock();      // song_clock: starts and stops the song; true while it plays
  bool playing_ = false;    // the timeline is set: follow_rate may move it
  size_t cursor_ = 0;       // next event to send
  unsigned loop_ = 0;       // loop of the next event
  std::deque<double> queued_ticks_;  // entries the board may still hold (their ticks)
  uint64_t clock_starts_ = 0;        // song_clock: its starts seen so far
  bool clock_playing_ = false, clock_pending_ = false;  // ... the song plays / waits for its grid
  std::FILE *clock_log_ = nullptr;
  const std::function<void(const PlayerProgress &)> *on_progress_ = nullptr;  // run's, while it runs
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_PLAYER_H

// midi_clock.h: jam following an external MIDI clock (24 ticks a quarter note, Start, Stop,
// Continue, Song Position Pointer): the clock's beat grid smoothed against its jitter, and the
// song's time laid on it through the song's tempo map.
//
// ClockFollower is the pure part: it takes clock messages with their host times and fits a
// line through the last kWindow ticks (least squares: a DAW's clock jitters by a millisecond or
// so, and MIDI through JACK moves once a period; four beats of ticks put the line within a
// tenth of that, a lead ahead), so a beat's host time is known ahead; a tempo change
// (three ticks in a row far off the line) restarts the fit from the change, anchored at the old
// line's last tick (a clock's ticks run on through a change), so the new tempo is followed
// within a few ticks. Ticks count while the clock is stopped too (DAWs send them), so
// the grid is known before Start: the tick after Start is beat 0, the tick after Continue the
// song position's.
//
// MidiClockTimeline is the player's SongClock (player.h): it drains the ClockQueue the MIDI
// callback fills, and maps song seconds to host time through the follower and the tempo map.
// Called from: the player's thread only. Its messages come from MidiIn (live/midi_in.h).
#ifndef STEPCHOIR_HOST_PLAYER_MIDI_CLOCK_H
#define STEPCHOIR_HOST_PLAYER_MIDI_CLOCK_H

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "live/midi_in.h"
#include "player/player.h"
#include "song/song.h"

namespace stepchoir {

class ClockFollower {
 public:
  static constexpr int kTicksPerBeat = 24;
  static constexpr size_t kWindow = 96;  // ticks the line is fitted through: four beats
  static constexpr int64_t kMaxLostRun = 24;  // a longer silence is a clock that paused
  static constexpr double kLostSlack = 0.25;  // after lost ticks the next comes a period on, within this
  static constexpr double kChangeUs = 3000;     // ticks this far off the line, kChangeRun in a row: a new tempo
  static constexpr size_t kChangeRun = 3;       // (further each time: a path holding ticks up goes back)
  static constexpr size_t kChangeMinTicks = 12;  // ticks on a line before a change to it is looked for
  static constexpr size_t kHingeTicks = 8;       // a change began at most this many ticks before it was seen
  static constexpr size_t kMaxHeld = 4;          // ticks after long gaps in a row held; more: a slower clock
  static constexpr double kTwinUs = 3000;        // a tick again within this (us) may be the same one twice

  // Takes one message (kMidiClock*), in arrival order.
  void take(const ClockMessage &m);

  bool running() const { return running_; }
  uint64_t starts() const { return starts_; }        // Start and Continue messages taken
  double start_beat() const { return start_beat_; }  // where the last one began (quarter notes)
  bool locked() const { return count_ >= 2; }        // the grid is known (two ticks or more)
  // Host time (us) of a beat (quarter notes from the song's start), and back. Locked only.
  double host_us_at(double beat) const;
  double beat_at(double host_us) const;
  double us_per_beat() const { return slope_ * kTicksPerBeat; }
  // Ticks taken, and ticks found missing: a tick that comes two or more of the grid's tick
  // periods after the one before stands for those it follows (a lossy MIDI path) when the next
  // comes a period after it and the two lie closer to the line counted so than as the next
  // ticks (held up, less each time); when the next comes right after it, it was late (a stalled
  // path delivers its ticks together), and late ticks are counted but kept out of the fit; when
  // the next comes later than a period, the clock slowed down. Until a tick tells which, a tick
  // after a long gap stays out of the fit (a tick 100 ms late would move the line by ms), and so
  // do up to kMaxHeld such in a row (lost ticks come in runs when JACK misses cycles); more in a
  // row are a slower clock.
  uint64_t ticks() const { return static_cast<uint64_t>(ticks_); }
  uint64_t lost_ticks() const { return lost_; }
  // Ticks that came twice, the second time right behind the first, and were taken once.
  uint64_t twin_ticks() const { return twins_; }
  // Tempo changes seen (each restarted the fit).
  uint64_t tempo_changes() const { return changes_; }

 private:
  struct Tick {
    int64_t n = 0;   // its number on the grid
    double us = 0;   // when it came (the first after a tempo change: its time on the old line)
  };
  // Host us of tick n on the line.
  double line_us(int64_t n) const { return intercept_ + slope_ * static_cast<double>(n); }
  void join(const Tick &tick);
  void join_held(bool lost);
  void fit();
  void note_change(const Tick &tick);
  size_t hinge_back(const Tick &tick) const;
  bool lost_fits_better(double us) const;
  std::array<Tick, kWindow> ring_{};  // the last ticks, oldest at ring_[next_ % kWindow] once full
  size_t next_ = 0;          // ticks put in the ring so far
  int64_t ticks_ = 0;        // the grid's ticks since the first (taken and lost)
  uint64_t lost_ = 0;
  uint64_t twins_ = 0;
  uint64_t changes_ = 0;
  double last_us_ = 0;       // when the last tick came
  struct Held {
    Tick tick;         // a tick that came after a long gap
    int64_t lost = 0;  // the ticks its gap stands for, if they were lost
  };
  std::array<Held, kMaxHeld> held_{};  // out of the fit until a tick a period on tells what they were
  size_t held_count_ = 0;
  size_t held_before_start_ = 0;  // of them, those before the last Start or Continue
  size_t count_ = 0;         // ticks in the ring
  size_t change_run_ = 0;    // ticks in a row more than kChangeUs off the line, one way
  int change_sign_ = 0;      // that way: +1 late, -1 early
  double change_residual_ = 0;  // the last tick's distance from the line, us
  double intercept_ = 0, slope_ = 0;  // host us of tick n: intercept_ + slope_ * n
  int64_t zero_tick_ = 0;    // the tick that is the song's beat 0 (after Start), or its position
  bool running_ = false;
  uint64_t starts_ = 0;
  double start_beat_ = 0;
  uint16_t position_ = 0;    // the last Song Position Pointer (sixteenths)
};

class MidiClockTimeline : public SongClock {
 public:
  // tempo: the song's tempo map; speed: the plan's tempo factor (song seconds / score seconds).
  MidiClockTimeline(ClockQueue &queue, std::vector<TempoPoint> tempo, double speed = 1.0);
  void poll() override;
  uint64_t starts() const override { return follower_.starts(); }
  bool running() const override { return follower_.running(); }
  bool locked() const override { return follower_.locked(); }
  double start_score_s() const override;
  double host_us(double score_s) const override;
  double score_at(double host_us) const override;
  const ClockFollower &follower() const { return follower_; }

 private:
  ClockQueue &queue_;
  Song tempo_song_;  // the tempo map alone (song_beat, song_seconds)
  double speed_;
  ClockFollower follower_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_MIDI_CLOCK_H

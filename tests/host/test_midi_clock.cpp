// test_midi_clock.cpp: following a MIDI clock: the clock messages parsed, the beat grid fitted
// through a jittered clock, Start, Stop, Continue and the song position, a tempo change followed
// within a beat, and song seconds laid on the grid through the song's tempo map.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "live/midi_in.h"
#include "player/midi_clock.h"
#include "song/song.h"

using namespace stepchoir;

namespace {

// Sends ticks at bpm from t_us (us) for `beats` beats, each jittered uniformly by +/- jitter_us;
// returns the time the next tick is due. period_us > 0: each comes at the start of the next
// period of that length, as MIDI through JACK does, stamped half a period earlier (MidiIn's
// clock_delay_us).
double send_ticks(ClockFollower &f, double t_us, double bpm, double beats, double jitter_us, std::mt19937 &rng,
                  double period_us = 0) {
  std::uniform_real_distribution<double> jitter(-jitter_us, jitter_us);
  const double tick_us = 60e6 / bpm / ClockFollower::kTicksPerBeat;
  for (int i = 0; i < int(std::lround(beats * ClockFollower::kTicksPerBeat)); ++i, t_us += tick_us) {
    double at = t_us + jitter(rng);
    if (period_us > 0) at = std::ceil(at / period_us) * period_us - period_us / 2;
    f.take({kMidiClockTick, 0, uint64_t(std::llround(at))});
  }
  return t_us;
}

}  // namespace

TEST_CASE("midi clock: the system messages parse, nothing else does", "[clock]") {
  ClockMessage m;
  const unsigned char tick[] = {0xF8}, spp[] = {0xF2, 0x10, 0x02}, note[] = {0x90, 60, 100}, short_spp[] = {0xF2, 1};
  REQUIRE(parse_clock_message(tick, 1, 7, &m));
  CHECK(m.status == kMidiClockTick);
  CHECK(m.t_us == 7u);
  REQUIRE(parse_clock_message(spp, 3, 9, &m));
  CHECK(m.status == kMidiSongPosition);
  CHECK(m.position == 0x10 + (0x02 << 7));
  for (unsigned char s : {kMidiClockStart, kMidiClockContinue, kMidiClockStop}) CHECK(parse_clock_message(&s, 1, 0, &m));
  CHECK_FALSE(parse_clock_message(note, 3, 0, &m));
  CHECK_FALSE(parse_clock_message(short_spp, 2, 0, &m));
}

TEST_CASE("midi clock: the grid through a clock jittered by 1 ms is within a fraction of one", "[clock]") {
  std::mt19937 rng(3);
  ClockFollower f;
  CHECK_FALSE(f.locked());
  double t = send_ticks(f, 1e9, 120, 2, 1000, rng);  // ticks before Start: the tempo is known
  f.take({kMidiClockStart, 0, uint64_t(t - 5000)});
  REQUIRE(f.running());
  REQUIRE(f.locked());
  CHECK(f.starts() == 1u);
  CHECK(f.start_beat() == 0.0);
  CHECK(f.host_us_at(0) == Approx(t).margin(700));  // beat 0: the tick after Start
  double worst = 0;
  for (int beat = 0; beat < 240; ++beat) {  // two minutes at 120 bpm
    // Before each beat's ticks: where the fit puts the next beat (the player sends that far ahead).
    worst = std::max(worst, std::fabs(f.host_us_at(beat + 0.5) - (t + 0.5 * 500000)));
    t = send_ticks(f, t, 120, 1, 1000, rng);
  }
  INFO("worst prediction half a beat ahead: " << worst << " us");
  CHECK(worst < 500);  // (3 sigma of a 96-tick fit, 12 ticks ahead, is 0.42 ms)
  CHECK(f.us_per_beat() == Approx(500000).epsilon(0.002));
  CHECK(f.beat_at(f.host_us_at(17.25)) == Approx(17.25));
}

TEST_CASE("midi clock: a tempo change is followed within one beat", "[clock]") {
  std::mt19937 rng(5);
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = send_ticks(f, 1e9, 120, 8, 1000, rng);
  const double beat_at_change = f.beat_at(t);
  t = send_ticks(f, t, 140, 1, 1000, rng);  // one beat at the new tempo
  CHECK(f.us_per_beat() == Approx(60e6 / 140).epsilon(0.01));
  // The next beat's tick, predicted, within a millisecond of the new grid.
  CHECK(f.host_us_at(beat_at_change + 2) == Approx(t + 60e6 / 140).margin(1000));
}

TEST_CASE("midi clock: a tempo change is seen within a few ticks, in time for the next beat's note", "[clock]") {
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    std::mt19937 rng(seed);
    ClockFollower f;
    f.take({kMidiClockStart, 0, 0});
    double t = send_ticks(f, 1e9, 110, 8, 1000, rng);
    const double beat_at_change = f.beat_at(t);
    // A third of a beat at 140 bpm (8 ticks): the player sends the next beat's note now, 0.29 s
    // ahead (jam's lead is 0.3 s).
    const double next_beat_us = t + 60e6 / 140;
    send_ticks(f, t, 140, 1.0 / 3, 1000, rng);
    INFO("seed " << seed);
    CHECK(f.host_us_at(beat_at_change + 1) == Approx(next_beat_us).margin(2000));  // the 2 ms target
    // Jitter alone never looks like a change: the grid stays on a minute of a steady clock.
    t = send_ticks(f, t + 8 * 60e6 / 140 / 24, 140, 128, 1000, rng);
    CHECK(f.us_per_beat() == Approx(60e6 / 140).epsilon(0.003));
  }
}

TEST_CASE("midi clock: the beat after a tempo change, sent a jam lead ahead, is within a millisecond",
          "[clock]") {
  // jam sends a note kClockLeadMs (100 ms) ahead: the note of the first beat after the change
  // goes out that long before it, some ticks into the new tempo, which the fit starts from the
  // old line's last tick. The clock jitters by +/-1 ms and, through JACK, moves once a 1.33 ms
  // period (MidiIn takes half of it off). A big change, a small one and a slowing one.
  struct Change {
    double from_bpm, to_bpm;
  };
  for (const Change c : {Change{110, 140}, Change{120, 126}, Change{140, 100}}) {
    for (const bool jack : {false, true}) {
      double worst = 0;
      for (unsigned seed = 1; seed <= 40; ++seed) {
        std::mt19937 rng(seed);
        ClockFollower f;
        f.take({kMidiClockStart, 0, 0});
        const double period_us = jack ? 64 / 48000.0 * 1e6 : 0;
        double t = send_ticks(f, 1e9, c.from_bpm, 96, 1000, rng, period_us);
        const double beat_at_change = f.beat_at(t);
        const double beat_us = 60e6 / c.to_bpm, tick_us = beat_us / ClockFollower::kTicksPerBeat;
        const double sent_us = beat_us - 100000;  // the lead before the beat
        send_ticks(f, t, c.to_bpm, std::floor(sent_us / tick_us) / 24, 1000, rng, period_us);
        worst = std::max(worst, std::fabs(f.host_us_at(beat_at_change + 1) - (t + beat_us)));
        CHECK(f.lost_ticks() == 0u);  // a clock slowing down by 1.4 loses no tick
      }
      INFO(c.from_bpm << " -> " << c.to_bpm << " bpm" << (jack ? " through JACK" : "") << ": worst of 40 clocks "
                      << worst << " us");
      CHECK(worst < (jack ? 1500 : 1200));
    }
  }
}

TEST_CASE("midi clock: stop, continue from the song position, start from the top", "[clock]") {
  std::mt19937 rng(7);
  ClockFollower f;
  double t = send_ticks(f, 1e9, 100, 1, 0, rng);
  f.take({kMidiClockStart, 0, uint64_t(t)});
  t = send_ticks(f, t, 100, 4, 0, rng);
  f.take({kMidiClockStop, 0, uint64_t(t)});
  CHECK_FALSE(f.running());
  t = send_ticks(f, t, 100, 2, 0, rng);  // the clock runs on while stopped
  f.take({kMidiSongPosition, 26, uint64_t(t)});  // sixteenth 26: beat 6.5
  f.take({kMidiClockContinue, 0, uint64_t(t)});
  CHECK(f.running());
  CHECK(f.starts() == 2u);
  CHECK(f.start_beat() == 6.5);
  CHECK(f.host_us_at(6.5) == Approx(t).margin(1));  // the next tick is that position's
  t = send_ticks(f, t, 100, 1, 0, rng);
  f.take({kMidiClockStart, 0, uint64_t(t)});
  CHECK(f.start_beat() == 0.0);
  CHECK(f.host_us_at(0) == Approx(t).margin(1));
}

TEST_CASE("midi clock: song seconds laid on the grid through the song's tempo map", "[clock]") {
  Song song;
  song.tempo = {{0, 0, 0.5}, {2, 4, 0.25}};  // 120 bpm for 4 beats, then 240
  CHECK(song_beat(song, 1.0) == Approx(2));
  CHECK(song_beat(song, 3.0) == Approx(8));
  CHECK(song_seconds(song, 8) == Approx(3.0));
  CHECK(song_seconds(song, 2) == Approx(1.0));
  CHECK(song_beat(Song{}, 1.5) == Approx(3));  // no map: 120 bpm
  ClockQueue q(64);
  MidiClockTimeline timeline(q, song.tempo);
  std::mt19937 rng(1);
  double t = 1e9;
  for (int i = 0; i < 24; ++i, t += 25000) q.enqueue({kMidiClockTick, 0, uint64_t(t)});  // 100 bpm
  q.enqueue({kMidiClockStart, 0, uint64_t(t)});
  timeline.poll();
  REQUIRE(timeline.locked());
  CHECK(timeline.start_score_s() == 0.0);
  // Song second 3 is beat 8: eight beats of the clock's 600 ms after beat 0.
  CHECK(timeline.host_us(3.0) == Approx(t + 8 * 600000).margin(1));
  CHECK(timeline.score_at(t + 8 * 600000) == Approx(3.0));
}

TEST_CASE("midi clock: a lost tick does not shift the grid", "[clock]") {
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = 1e9;
  const double tick = 20000;  // 125 bpm
  for (int i = 0; i < 48; ++i, t += tick)
    if (i != 30 && i != 40 && i != 41) f.take({kMidiClockTick, 0, uint64_t(t)});  // three lost
  CHECK(f.lost_ticks() == 3u);
  CHECK(f.ticks() == 48u);
  CHECK(f.host_us_at(2.0) == Approx(t).margin(1));  // tick 48 is beat 2
}

TEST_CASE("midi clock: a tick lost just before Start leaves beat 0 on the tick after Start", "[clock]") {
  // Tick 46 lost: tick 47 comes two periods after 45, Start, then tick 48, a period on, tells
  // that 47 was on time. Beat 0 is tick 48 (counted from the ticks before Start, it was 47).
  ClockFollower f;
  double t = 1e9;
  const double tick = 22727;  // 110 bpm
  for (int i = 0; i < 48; ++i, t += tick) {
    if (i != 46) f.take({kMidiClockTick, 0, uint64_t(t)});
    if (i == 47) f.take({kMidiClockStart, 0, uint64_t(t + 12000)});
  }
  for (int i = 48; i < 96; ++i, t += tick) f.take({kMidiClockTick, 0, uint64_t(t)});
  CHECK(f.lost_ticks() == 1u);
  CHECK(f.ticks() == 96u);
  CHECK(f.host_us_at(0) == Approx(1e9 + 48 * tick).margin(1));
  CHECK(f.host_us_at(2.0) == Approx(t).margin(1));  // tick 96 is beat 2
}

TEST_CASE("midi clock: ticks lost a tick apart are both put back, a clock at half the tempo loses none",
          "[clock]") {
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = 1e9;
  const double tick = 20000;  // 125 bpm
  for (int i = 0; i < 96; ++i, t += tick)
    if (i != 50 && i != 52) f.take({kMidiClockTick, 0, uint64_t(t)});  // 51 and 53 each after a double gap
  CHECK(f.lost_ticks() == 2u);
  CHECK(f.ticks() == 96u);
  CHECK(f.host_us_at(4.0) == Approx(t).margin(1));  // tick 96 is beat 4
  // The clock drops to half the tempo: every tick after a double gap, which is not a run of
  // lost ticks once more than kMaxHeld come so in a row.
  for (int i = 0; i < 48; ++i, t += 2 * tick) f.take({kMidiClockTick, 0, uint64_t(t)});
  CHECK(f.lost_ticks() == 2u);
  CHECK(f.ticks() == 144u);
  CHECK(f.us_per_beat() == Approx(48 * tick).epsilon(0.01));
}

TEST_CASE("midi clock: two ticks held up, less each time, are neither lost ones nor a new tempo", "[clock]") {
  // A stalled path: tick 60 comes 12 ms late (1.6 periods after tick 59), tick 61 8 ms late
  // (0.8 periods after 60), then the clock is back on time. Counted as lost, the grid would
  // move by a tick (20 ms); taken for a tempo change, the next beats would follow a tempo that
  // is not there.
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = 1e9;
  const double tick = 20000;  // 125 bpm
  for (int i = 0; i < 96; ++i, t += tick)
    f.take({kMidiClockTick, 0, uint64_t(t + (i == 60 ? 12000 : i == 61 ? 8000 : 0))});
  CHECK(f.lost_ticks() == 0u);
  CHECK(f.ticks() == 96u);
  CHECK(f.us_per_beat() == Approx(24 * tick).epsilon(0.001));
  CHECK(f.host_us_at(4.0) == Approx(t).margin(500));  // tick 96 is beat 4
}

TEST_CASE("midi clock: ticks held up and delivered together are not taken for lost ones", "[clock]") {
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = 1e9;
  const double tick = 20000;
  for (int i = 0; i < 48; ++i, t += tick) {
    // Ticks 30 and 31 held up (a stalled path) and delivered with tick 32.
    const double at = (i == 30 || i == 31) ? t + (32 - i) * tick : t;
    f.take({kMidiClockTick, 0, uint64_t(at)});
  }
  CHECK(f.lost_ticks() == 0u);
  CHECK(f.ticks() == 48u);
  CHECK(f.host_us_at(2.0) == Approx(t).margin(1));
}

namespace {

// Replays a capture of what jam took through JACK (tests/data/clock/NAME.ticks: ticks lost inside
// JACK, others held up and delivered together, or delivered twice; a tempo change at
// change_beat). Where the sender's log fixes a tick's number, the follower's count must agree
// once the tick after a gap has told lost from late; and the line must have put each such tick
// within 2 ms of its place on the sender's grid five ticks (89-114 ms) before it came, as jam
// sends a note 100 ms ahead (issue 25's bound for onsets, which jam lays on that line).
// judge_line false: the capture's path held ticks 3-5 ms late for a beat after the tempo change,
// and the line through the few ticks since the change follows them (the counts are judged).
void replay_capture(const std::string &name, double change_beat, bool judge_line = true) {
  std::ifstream in(std::string(STEPCHOIR_TEST_DATA) + "/clock/" + name + ".ticks");
  REQUIRE(in);
  const double t0_us = 1e9;  // the capture's times are from its first message
  ClockFollower f;
  std::string line;
  int64_t prev_truth = -3, last_truth = -1, start_tick = -1;
  bool after_start = false;
  size_t taken = 0, twice = 0, checked = 0, miscounted = 0, judged = 0;
  double worst_us = 0, sum_us = 0;
  constexpr int64_t kAhead = 8;
  std::array<std::pair<int64_t, double>, kAhead> predicted{};  // tick number, where the line put it
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream row(line);
    int status = 0;
    double t_us = 0, grid_us = 0;
    int64_t truth = -1;
    REQUIRE((row >> status >> t_us >> truth >> grid_us));
    if (status == kMidiClockStart) after_start = true;
    f.take({uint8_t(status), 0, uint64_t(std::llround(t0_us + t_us))});
    if (status != kMidiClockTick) continue;
    ++taken;
    if (after_start) start_tick = truth, after_start = false;  // beat 0, by the sender's log
    if (truth == -2) ++twice;
    const auto beat_of = [&](int64_t tick) { return double(tick - start_tick) / ClockFollower::kTicksPerBeat; };
    if (start_tick >= 0) {  // the line now, five ticks ahead
      const int64_t ahead = int64_t(f.ticks()) + 4;
      predicted[size_t(ahead % kAhead)] = {ahead, f.host_us_at(beat_of(ahead))};
    }
    if (truth >= 0 && truth == prev_truth + 1) {  // no tick lost just before it: the count is settled
      ++checked;
      if (int64_t(f.ticks()) - 1 != truth) ++miscounted;
      // Past the first beat after Start, not within a beat of the tempo change (the tests above
      // hold the change's first beat).
      const double beat = start_tick >= 0 ? beat_of(truth) : -1;
      const auto &p = predicted[size_t(truth % kAhead)];
      if (beat > 1 && std::fabs(beat - change_beat) > 1 && p.first == truth) {
        const double err = p.second - (t0_us + grid_us);
        worst_us = std::max(worst_us, std::fabs(err));
        sum_us += err;
        ++judged;
      }
    }
    if (truth >= 0) last_truth = truth;
    if (truth != -2) prev_truth = truth;
  }
  INFO(name << ": " << taken << " ticks taken, " << twice << " twice; " << checked << " checked, " << miscounted
            << " miscounted; five ticks ahead, the line " << sum_us / double(judged)
            << " us from the grid on average, at worst " << worst_us << " us");
  CHECK(judged > taken * 9 / 10);
  CHECK(miscounted == 0u);
  CHECK(f.ticks() == uint64_t(last_truth + 1));                      // ticks taken and lost
  CHECK(f.twin_ticks() == twice);                                     // every tick that came twice taken once
  CHECK(f.lost_ticks() == uint64_t(last_truth + 1) - (taken - twice));  // every lost tick put back
  CHECK(f.tempo_changes() == 1u);  // the clock's own, not a path holding ticks up
  if (judge_line) CHECK(worst_us < 2000);
}

}  // namespace

TEST_CASE("midi clock: through JACK in an xrun storm, every tick is counted and the grid holds", "[clock]") {
  replay_capture("jack-xrun-storm", 96);  // two minutes: 12 ticks lost, others held up
}

TEST_CASE("midi clock: a tick JACK delivers twice is taken once", "[clock]") {
  replay_capture("jack-twin-tick", 24);  // half a minute: 4 ticks lost, one delivered twice
}

TEST_CASE("midi clock: through JACK, a tick lost just before Start leaves the grid on its beat", "[clock]") {
  replay_capture("jack-lost-before-start", 96);  // two minutes: 11 ticks lost
}

TEST_CASE("midi clock: through JACK in a heavy xrun storm, lost ticks in runs are all put back", "[clock]") {
  // Two minutes, 8,411 JACK xruns: 76 ticks lost, some a tick apart, two delivered twice. Each
  // tick after a long gap waits for one a period on; ticks after long gaps in a row wait together.
  replay_capture("jack-lost-runs", 96, false);
}

TEST_CASE("midi clock: a tick right behind itself is taken once, a tempo twice as fast followed", "[clock]") {
  ClockFollower f;
  f.take({kMidiClockStart, 0, 0});
  double t = 1e9;
  const double tick = 20000;  // 125 bpm
  for (int i = 0; i < 48; ++i, t += tick) {
    f.take({kMidiClockTick, 0, uint64_t(t)});
    if (i == 30) f.take({kMidiClockTick, 0, uint64_t(t + 30)});  // JACK's cycle delivered twice
  }
  CHECK(f.twin_ticks() == 1u);
  CHECK(f.ticks() == 48u);
  CHECK(f.host_us_at(2.0) == Approx(t).margin(1));  // tick 48 is beat 2
  // The clock jumps to 2.2 times the tempo: its ticks come 9 ms apart, each a new one.
  for (int i = 0; i < 48; ++i, t += tick / 2.2) f.take({kMidiClockTick, 0, uint64_t(t)});
  CHECK(f.twin_ticks() == 1u);
  CHECK(f.ticks() == 96u);
  CHECK(f.us_per_beat() == Approx(24 * tick / 2.2).epsilon(0.01));
}

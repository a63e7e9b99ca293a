// test_jam_clock.cpp: `stepchoir jam --midi-clock` following a DAW-like MIDI clock through JACK:
// 24 ticks a beat, each sent up to 1 ms off its time, Start, a tempo change, Stop. The song's
// onsets, read from the virtual board's trace and laid on the machine's monotonic clock, against
// the clock's own beat grid (its ticks' times without the jitter), for 23 s (two minutes on
// request): the song takes the clock's tempo (not its own) on both sides of the change, and
// stays on its grid.
// Every onset within 2 ms of the grid, the first at the new tempo included (issue 25's bound). The
// verdict needs the virtual board in real time (the `pacing` label): a failure says how far the
// machine stalled the board. Figures: bench/results/jam-midi-clock.md.
#include <catch2/catch.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "core/midi_event.h"
#include "jack_rig.h"
#include "play_checks.h"
#include "score.h"
#include "smf_builder.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
namespace tr = sc::trace;

namespace {

// A song at its own 120 bpm: a quarter-length note on every beat for `beats` beats, rising and
// falling by step (each note a new pitch: every onset is a new segment in the trace).
std::string write_beat_song(const std::string &name, int beats) {
  const uint16_t ppq = 480;
  std::vector<smf::Track> tracks(2);
  tracks[0].tempo(0, 500000).end(0);
  const int scale[8] = {60, 62, 64, 65, 67, 65, 64, 62};
  for (int b = 0; b < beats; ++b) {
    const uint8_t note = static_cast<uint8_t>(scale[b % 8]);
    tracks[1].ev(0, {0x90, note, 90}).ev(ppq / 2, {0x80, note, 0}).ev(ppq / 2, {0xB0, 7, 100});
  }
  tracks[1].end(0);
  const auto bytes = smf::file(1, ppq, tracks);
  const std::string path = scratch(name);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char *>(bytes.data()),
                                               static_cast<std::streamsize>(bytes.size()));
  return path;
}

}  // namespace

TEST_CASE("jam: the song follows a jittered MIDI clock's tempo and beat grid",
          "[play][jam][pacing]") {
  JackServer jack(64);  // 1.3 ms periods: MIDI moves once a period
  Sender daw;
  // 23 s in CI: 110 bpm for 24 beats (13.1 s), then 140 bpm for 24 (10.3 s). The two
  // minutes (96 and 128 beats): STEPCHOIR_JAM_CLOCK_LONG=1 build/bin/test_e2e "jam: the song follows*".
  const bool long_run = std::getenv("STEPCHOIR_JAM_CLOCK_LONG") != nullptr;
  const int beats = long_run ? 224 : 48;
  const int change_beat = long_run ? 96 : 24;
  const std::string song = write_beat_song("jam-clock.mid", beats);
  const std::string trace_path = scratch("jam-clock.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // The board stands in for hardware with its own clock: it goes first on a busy machine, whose
  // stalls the host's lead absorbs (root only; elsewhere the test runs as it is).
  setpriority(PRIO_PROCESS, static_cast<id_t>(vb.pid()), -10);
  ChildProcess jam({STEPCHOIR_BIN, "jam", song, "--midi-clock", "--midi-api", "jack", "--midi", Sender::kPort, "--port",
                    vb.pty(), "--song-motors", "0", "--quiet"},
                   true);
  std::string said;
  const std::string line = wait_for_line(jam, "jam: the song follows the MIDI clock", &said);
  INFO(said);
  REQUIRE(line.find("waiting for Start") != std::string::npos);
  // The DAW: two beats of ticks while stopped, Start, the song's beats and two more, Stop. Each
  // tick's time on the grid is kept; it goes out up to 1 ms off it.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.001, 0.001);
  std::vector<double> beat_s;  // the grid: host time of each beat after Start
  double t = Sender::now_s() + 0.2;
  auto tick_at = [&](double when) {
    const double wait = when + jitter(rng) - Sender::now_s();
    if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    daw.send_byte(kMidiClockTick);
  };
  for (int i = 0; i < 48; ++i, t += 60.0 / 110 / 24) tick_at(t);
  std::this_thread::sleep_for(std::chrono::duration<double>(t - 0.01 - Sender::now_s()));
  daw.send_byte(kMidiClockStart);
  for (int b = 0; b < beats + 2; ++b) {
    beat_s.push_back(t);
    const double tick = 60.0 / (b < change_beat ? 110 : 140) / 24;
    for (int i = 0; i < 24; ++i, t += tick) tick_at(t);
  }
  daw.send_byte(kMidiClockStop);
  const std::string out = jam.read_rest(60000);
  REQUIRE(jam.wait() == 0);
  vb.stop();
  INFO(out);
  const tr::Trace tt = tr::read_trace(trace_path);
  REQUIRE(tt.has_wall_start);
  require_real_time(tt);  // a board that gave up real time puts its onsets off the machine's clock
  const auto notes = tr::segment_notes(tt.motor.at(0).steps, tt.f_cpu_hz);
  REQUIRE(int(notes.size()) == beats);
  // Each onset against its beat, on the machine's clock.
  double worst = 0, worst_after_change = 0, sum = 0;
  int worst_beat = -1;
  std::vector<double> errs, before, after;  // errors; inter-onset intervals on each tempo
  for (int b = 0; b < beats; ++b) {
    const double on = tt.wall_seconds(tt.real_seconds(notes[size_t(b)].start_cycle));
    const double err = on - beat_s[size_t(b)];
    if (std::getenv("STEPCHOIR_TEST_NOTES")) std::printf("beat %d: %+.3f ms\n", b, 1e3 * err);
    if (b > 0 && b < change_beat) before.push_back(double(notes[size_t(b)].start_cycle - notes[size_t(b) - 1].start_cycle));
    if (b > change_beat + 2) after.push_back(double(notes[size_t(b)].start_cycle - notes[size_t(b) - 1].start_cycle));
    // The first beat at the new tempo: its note goes out a lead (0.3 s) ahead, a few ticks
    // after the change.
    if (b == change_beat + 1) worst_after_change = std::fabs(err);
    sum += err;
    errs.push_back(std::fabs(err));
    if (std::fabs(err) > worst) worst = std::fabs(err), worst_beat = b;
  }
  std::sort(errs.begin(), errs.end());
  std::sort(before.begin(), before.end());
  std::sort(after.begin(), after.end());
  const double beat_before = before[before.size() / 2] / tt.real_f_cpu_hz(), beat_after = after[after.size() / 2] / tt.real_f_cpu_hz();
  std::printf("jam on a MIDI clock: %d onsets, mean %+.3f ms from the grid, median %.3f ms, worst %.3f ms (beat %d); "
              "the first beat at the new tempo %.3f ms; beats %.4f s (clock %.4f) and %.4f s (clock %.4f)\n",
              beats, 1e3 * sum / double(errs.size()), 1e3 * errs[errs.size() / 2], 1e3 * worst, worst_beat,
              1e3 * worst_after_change, beat_before, 60.0 / 110, beat_after, 60.0 / 140);
  // The clock's tempo, not the song's own 120 bpm, on both sides of the change.
  CHECK(beat_before == Approx(60.0 / 110).epsilon(0.002));
  CHECK(beat_after == Approx(60.0 / 140).epsilon(0.002));
  // On the clock's grid, every beat within 2 ms (free-running, the song would be seconds off it
  // by the end), and the tempo change followed by the next beat (at the old tempo it would be
  // 117 ms late).
  INFO("the machine stalled the virtual board by up to " << tr::pacing_lag_max_us(tt) / 1000.0 << " ms, "
       << tr::pacing_lag_max_s(tt) << " s into its trace; beat " << worst_beat << " was at "
       << tt.real_seconds(notes[size_t(worst_beat)].start_cycle) << " s");
  CHECK(worst < 0.002);
  CHECK(worst_after_change < 0.002);
}

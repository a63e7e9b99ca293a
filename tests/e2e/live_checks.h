// live_checks.h: what the `stepchoir live` end-to-end tests share: their tolerances, the notes a
// trace shows, waiting for live to say something, and the pause before the first key
// (test_live.cpp, test_live_rig.cpp).
#ifndef STEPCHOIR_TESTS_E2E_LIVE_CHECKS_H
#define STEPCHOIR_TESTS_E2E_LIVE_CHECKS_H

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "trace.h"

namespace live_checks {

namespace tr = sc::trace;

// How far a note's start or end may sit from when it was sent: the JACK period (21 ms),
// the path through the host and the line, and a loaded machine's scheduling.
inline const double kTimeToleranceS = 0.045;
// Pitch: a segment's mean interval against the note (semitones; 0.02 = 2 cents).
inline const double kPitchToleranceSemitones = 0.02;
// A velocity below [velocity]'s default double_at (live/velocity.h): a note on one motor.
inline constexpr uint8_t kSoft = 64;

// One note the board played, on the board's clock.
struct Played {
  int motor;
  double start_s, end_s, pitch;
};

// Every note segment of every motor of a trace.
inline std::vector<Played> played_notes(const tr::Trace &t) {
  std::vector<Played> out;
  for (int m = 0; m < t.motors; ++m)
    for (const auto &s : tr::segment_notes(t.motor[m].steps, t.f_cpu_hz))
      out.push_back({m, t.board_seconds(s.start_cycle), t.board_seconds(s.end_cycle), s.midi_note});
  std::sort(out.begin(), out.end(), [](const Played &a, const Played &b) { return a.start_s < b.start_s; });
  return out;
}

// How far the virtual board's clock may have drifted from the wall clock (s): its worst lag
// plus the time it gave up catching up, from its trace summary.
inline double pacing_error_s(const tr::Trace &t) {
  double total_s = 0;
  for (const auto &line : t.summary_lines)
    for (const char *key : {"pacing_lag_max_us=", "pacing_slipped_us="}) {
      const size_t at = line.find(key);
      if (at != std::string::npos) total_s += std::stod(line.substr(at + std::strlen(key))) / 1e6;
    }
  return total_s;
}

// Reads the process's stdout until a line contains text (true) or 20 s pass without one.
inline bool wait_for_line(stepchoir::ChildProcess &process, const std::string &text) {
  for (std::string line; process.read_line(&line, 20000);)
    if (line.find(text) != std::string::npos) return true;
  return false;
}

// Called from: each test once `stepchoir live` said it is connected. Lets the JACK graph take
// the new connection before the first note (events in that cycle could be lost).
inline void settle() { std::this_thread::sleep_for(std::chrono::milliseconds(300)); }

// Reads live's first line, which must name `ready` (its motors and policy), then settles.
inline void wait_ready(stepchoir::ChildProcess &live, const std::string &ready) {
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  INFO("stepchoir live said: " << line);
  REQUIRE(line.find(ready) != std::string::npos);
  settle();
}

}  // namespace live_checks

#endif  // STEPCHOIR_TESTS_E2E_LIVE_CHECKS_H

// test_score.cpp: check_score lines a score up with a synthetic trace: the offset found from
// the notes' starts and pitches, and a song that repeats (several offsets as good) said so.
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "score.h"
#include "synth_trace.h"
#include "trace.h"

using sc::trace::ScoreCheck;
using sc::trace::ScoreNote;

namespace {

// Motor 0 plays 48 staccato notes, one every 125 ms (on for 62.5 ms), from 1.0 s of the trace;
// the score is the part's last 12 notes in song seconds (the song's 0 s is the trace's 1.0 s),
// as a test checks a song's end. repeats: the pitches go round every 8 notes; else a fixed draw.
ScoreCheck check_last_notes(bool repeats) {
  std::vector<synth::Note> part;
  std::vector<ScoreNote> score;
  uint32_t draw = 1;
  for (int i = 0; i < 48; ++i) {
    draw = draw * 1103515245u + 12345u;
    const double pitch = 60 + (repeats ? i % 8 : (draw >> 16) % 12);
    part.push_back({pitch, 1.0 + i * 0.125, 0.0625});
    if (i >= 36) score.push_back({0, i * 0.125, i * 0.125 + 0.0625, pitch, -1});
  }
  return sc::trace::check_score(sc::trace::parse_trace(synth::make_trace_text({part}, 8.0)), score);
}

}  // namespace

TEST_CASE("score: a song's end lines up at its own offset - one that repeats lines up at several, and says so",
          "[score]") {
  const ScoreCheck own = check_last_notes(false);
  CHECK(own.offsets_tied == 0);
  CHECK(own.found == 12);
  CHECK(own.line_offset_s == Approx(1.0).margin(1e-5));
  CHECK(own.max_cents < 0.01);
  CHECK(own.max_release_late_us < 1.0);

  // Every note matches a note of the same pitch a second (8 notes) earlier or later: the check
  // cannot tell which notes are the song's end, and says so.
  const ScoreCheck repeating = check_last_notes(true);
  CHECK(repeating.offsets_tied > 0);
}

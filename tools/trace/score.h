// score.h: a song as the board played it, against the score: each note's onset, pitch and end
// in the virtual board's trace (pure; used by the song player's tests and benchmark).
#ifndef STEPCHOIR_TRACE_SCORE_H
#define STEPCHOIR_TRACE_SCORE_H

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

#include "trace.h"

namespace sc {
namespace trace {

// One note the board should have played: which motor, from when to when (seconds of the
// song), at what pitch (fractional MIDI note number, A4 = 69 = 440 Hz).
struct ScoreNote {
  size_t motor = 0;
  double on_s = 0, off_s = 0;
  double midi_note = 0;
  // 1: the motor was silent (at least 8 ms) before this note, 0: it follows another note;
  // -1: check_score works it out from the notes it is given (give it when they are a part of
  // a song).
  int after_silence = -1;
};

// What the trace shows of the score's notes, in real time (cycles / the simulated crystal's
// real rate).
struct ScoreCheck {
  size_t notes = 0, found = 0;
  std::vector<double> onset_err_us;  // per note: first edge - the song's time on the board's line
  double tempo_ppm = 0;              // the line's slope: song seconds -> real seconds, - 1
  double line_offset_s = 0;          // the line: song second s is real second offset + s * (1 + tempo_ppm/1e6)
  double max_release_late_us = 0;    // an edge after a note's end (+: the motor went on)
  double max_release_early_us = 0;   // end - (last edge + one period) (+: the note stopped early)
  double max_cents = 0;              // pitch error in real time, worst note
  double max_spread_cents = 0;       // pitch error against the notes' median error (in tune together)
  size_t turned = 0;                 // notes during which the motor turned round (no pitch measured)
  size_t offsets_tied = 0;           // other offsets at which the score lines up with the trace as
                                     // well (a song that repeats: which notes are which is a guess)
  std::string first_problem;
};

// Checks every score note (in onset order) against the trace. The song's timeline on the board
// is the line through the notes' onsets (a constant offset, and a tempo); each note must start
// on it (its first rising edge: a silent motor starts on the time, a sounding one strikes on
// it), sound at its pitch and stop at its end (no edge after it until the motor's next note).
// detail (may be null) gets one line per note. Called from: the player's e2e tests, its bench.
ScoreCheck check_score(const Trace &t, const std::vector<ScoreNote> &notes, std::FILE *detail = nullptr);

// How much real time the virtual board lost (us): it paces simulated time to the wall clock,
// and on a machine too busy to simulate in real time it falls behind and slips. Its clock then
// runs slow against the host's for a moment, as no crystal does. From the trace's summary; -1
// when it has none. Called from: the player's e2e tests, its bench.
long pacing_slipped_us(const Trace &t);
// How far (us) the virtual board fell behind real time at worst, given up or caught up; -1 when
// the trace has no summary. A lag distorts what the host measured of the board's clock meanwhile.
// Called from: end-to-end tests that judge several boards against one time line.
long pacing_lag_max_us(const Trace &t);
// Where (real seconds into the trace) it fell that far behind; -1 when the trace has no summary.
double pacing_lag_max_s(const Trace &t);
// Host bytes that reached the virtual board while its UART was off (a bootloader, or the
// firmware not yet started): lost, as on a real board; -1 when the trace has no summary.
// Called from: the live bench, to tell those from bytes the board got and found bad.
long uart_in_lost(const Trace &t);

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_SCORE_H

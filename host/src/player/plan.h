// plan.h: a song -> which motor plays which note, and the per-motor timeline of pitches and
// silences the player sends (pure; the whole song is known, so allocation looks ahead).
#ifndef STEPCHOIR_HOST_PLAYER_PLAN_H
#define STEPCHOIR_HOST_PLAYER_PLAN_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "live/allocator.h"
#include "song/song.h"

namespace stepchoir {

struct PlanOptions {
  double tempo_scale = 1.0;          // 2 = twice as fast
  int transpose = 0;                 // semitones, before each motor's own transpose and folding
  std::vector<int> tracks;           // play only these tracks (empty: all)
  std::vector<int> channels;         // play only these MIDI channels, 0-15 (empty: all)
  std::vector<int> mute_tracks, mute_channels;
  double start_s = 0;                // start this far into the song (score seconds)
  double min_note_s = 0.01;          // shorter notes are left out (a stepper only clicks)
  std::vector<MotorConfig> motors;   // one per motor that plays the song (range, tuning, mutes)
};

// A note as a motor plays it. Times in seconds from the (scaled, started) song's start.
struct PlannedNote {
  double on_s = 0, off_s = 0;
  uint8_t motor = 0;      // index into PlanOptions::motors
  double pitch = 0;       // MIDI note number played (folded, transposed) + tuning cents / 100
  uint32_t song_index = 0;  // index into Song::notes
};

// Why a song note is not played as written.
enum class Unplayed : uint8_t { kNoMotor, kTooShort, kOutOfRange };

struct UnplayedNote {
  uint32_t song_index;
  Unplayed why;
};

struct Plan {
  std::vector<PlannedNote> notes;       // by onset
  std::vector<UnplayedNote> unplayed;   // selected notes that do not sound
  size_t shortened = 0;                 // notes cut short so that another could take the motor
  size_t selected = 0;                  // notes the selection kept (tracks, channels, start)
  double duration_s = 0;                // (scaled, started) song length
};

// One change of one motor: at time_s, play pitch (a MIDI note number, fractional), or fall
// silent. The player turns pitch into a period with the board's measured clock rate.
struct PlanEvent {
  double time_s = 0;
  uint8_t motor = 0;
  bool silent = true;
  double pitch = 0;
};

// A repeated note on one motor would run on as one: it is cut this much short, so the next
// one is heard striking.
constexpr double kRestrikeGapS = 0.01;

// Assigns the song's notes to motors. Called from: the play/render/jam commands and tests.
// Throws std::invalid_argument when there is no motor or the options are out of range.
Plan plan_song(const Song &song, const PlanOptions &options);

// The timeline of a plan: sorted by time, then motor; a motor's silence at the very time its
// next note starts is left out (the note strikes at once). Called from: the player, tests.
std::vector<PlanEvent> plan_events(const Plan &plan);

// "why" in words, for reports. Called from: the play command.
const char *unplayed_reason(Unplayed why);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_PLAN_H

// plan.h: a song -> which motor plays which note, and the per-motor timeline of pitches and
// silences the player sends (pure; the whole song is known, so allocation looks ahead).
//
// The plan arranges like a player reducing a score to a few instruments (arranger.h says who is
// melody, bass or inner voice): percussion is never sung as a pitch; the melody takes motors
// first, then the bass, then inner voices by what they add; a unison or octave doubling of a
// note already sounding takes a motor only when one is left free; a line stays on its motor; a
// note out of a motor's range folds by octaves before it is dropped.
#ifndef STEPCHOIR_HOST_PLAYER_PLAN_H
#define STEPCHOIR_HOST_PLAYER_PLAN_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "live/allocator.h"
#include "song/song.h"

namespace stepchoir {

// What a note is to a listener (arranger.h decides).
enum class Role : uint8_t { kMelody, kBass, kInner, kPercussion };
constexpr size_t kRoleCount = 4;

// A line of the song by its track or its MIDI channel (0-15), for --voices.
struct LineSelector {
  bool by_channel = false;
  int value = 0;
};

struct PlanOptions {
  double tempo_scale = 1.0;          // 2 = twice as fast
  int transpose = 0;                 // semitones, before each motor's own transpose and folding
  std::vector<int> tracks;           // play only these tracks (empty: all)
  std::vector<int> channels;         // play only these MIDI channels, 0-15 (empty: all)
  std::vector<int> mute_tracks, mute_channels;
  double start_s = 0;                // start this far into the song (score seconds)
  double min_note_s = 0.01;          // shorter notes are left out (a stepper only clicks)
  std::vector<MotorConfig> motors;   // one per motor that plays the song (range, tuning, mutes)
  int drum_motor = -1;               // >= 0: percussion plays as short bursts on this motor (an
                                     // index into motors), which then sings nothing else
  std::vector<Role> keep;            // roles that play (empty: melody, bass and inner voices);
                                     // a line named in voices plays whatever its role
  std::vector<LineSelector> voices;  // pitched lines that take motors before the arranger's
                                     // order, in this order (empty: the arranger decides)
};

// A note as a motor plays it. Times in seconds from the (scaled, started) song's start.
struct PlannedNote {
  double on_s = 0, off_s = 0;
  uint8_t motor = 0;      // index into PlanOptions::motors
  double pitch = 0;       // MIDI note number played (folded, transposed) + tuning cents / 100
  uint32_t song_index = 0;  // index into Song::notes
  Role role = Role::kInner;
  int8_t octaves = 0;     // octaves the note moved to fit the motor's range (+ up, - down)
};

// Why a song note is not played as written.
enum class Unplayed : uint8_t {
  kNoMotor,      // every motor that can play it busy with notes that matter more
  kTooShort,     // shorter than PlanOptions::min_note_s
  kOutOfRange,   // no motor can play its pitch (every octave of it muted or out of range)
  kPercussion,   // a drum hit, and no drum motor
  kDoubled,      // a unison or octave of a note already sounding on a motor
  kNotKept,      // its role is not in PlanOptions::keep
  kDrumTogether, // a drum hit with another one (within kDrumHitGapS) that matters more
};
constexpr size_t kUnplayedCount = 7;

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

// True when the options select a song note: its track and channel chosen and not muted, and
// it still sounds after the start position. Called from: plan_song, the arrangement
// benchmark's baseline.
bool note_selected(const SongNote &note, const PlanOptions &options);

// Assigns the song's notes to motors. Called from: the play/render/jam commands and tests.
// Throws std::invalid_argument when there is no motor or the options are out of range.
Plan plan_song(const Song &song, const PlanOptions &options);

// The timeline of a plan: sorted by time, then motor; a motor's silence at the very time its
// next note starts is left out (the note strikes at once). Called from: the player, tests.
std::vector<PlanEvent> plan_events(const Plan &plan);

// "why" and a role in words, for reports. Called from: the play command.
const char *unplayed_reason(Unplayed why);
const char *role_name(Role role);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_PLAN_H

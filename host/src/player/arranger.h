// arranger.h: what each note of a song is to a listener (melody, bass or inner voice) and the
// order in which the planner offers it a motor (pure).
//
// The melody is the song's highest line: a note that is the highest sounding pitched note for
// at least half of its length, or one that is the highest note of the lead track for at least
// half of its length: the one track whose name says lead, melody, vocal or solo (when several
// tracks do, they are parts, and the texture decides). The bass is the lowest line: a note
// that is the lowest sounding one for at least half of its length. Everything else is an inner
// voice. Percussion is neither.
//
// Order: the lines the user named (--voices), in the order named, each by onset; then the
// melody and the bass by onset, each note as it comes, so that each line finds its motor
// again (at one onset the outer note first); then the inner voices, the ones that add most
// first: the longer, the louder, and the more of their length they spend at the top or bottom
// of the texture.
#ifndef STEPCHOIR_HOST_PLAYER_ARRANGER_H
#define STEPCHOIR_HOST_PLAYER_ARRANGER_H

#include <cstdint>
#include <string>
#include <vector>

#include "player/plan.h"
#include "song/song.h"

namespace stepchoir {

// A selected note, on the plan's time line.
struct ArrangedNote {
  uint32_t song_index = 0;
  double on_s = 0, off_s = 0;  // scaled and started, as PlannedNote
  int key = 0;                 // MIDI note after the plan's transpose (may leave 0-127)
  uint16_t track = 0;
  uint8_t channel = 0;
  Role role = Role::kInner;
  int named = -1;              // index into PlanOptions::voices of the line it belongs to, or -1
  double top_s = 0;            // how long it is the highest sounding pitched note
  double bottom_s = 0;         // how long it is the lowest
};

// True when a track name marks the song's lead line (lead, melody, vocal, solo; any case).
// Called from: arrange_notes.
bool lead_track_name(const std::string &name);

// Sets each note's role, named line and top/bottom times (percussion notes keep kPercussion
// and take no part), and returns the indexes into notes in the order motors are offered.
// Called from: plan_song. O(n log n).
std::vector<uint32_t> arrange_notes(std::vector<ArrangedNote> &notes, const Song &song, const PlanOptions &options);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_ARRANGER_H

// song.h: a song as the players and the G-code writer see it (notes in absolute seconds), and
// the readers of song files (.sng and Standard MIDI Files) that build one.
#ifndef STEPCHOIR_HOST_SONG_SONG_H
#define STEPCHOIR_HOST_SONG_SONG_H

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/midi_event.h"

namespace stepchoir {

// One note of a song: when it starts and how long it lasts, in seconds from the song's start.
struct SongNote {
  double onset_s = 0;      // start, seconds from the start of the song
  double duration_s = 0;   // length in seconds, > 0
  uint8_t midi_note = 0;   // 0-127, 69 = A4
  uint8_t velocity = 0;    // 1-127 (a .sng note has 100)
  uint16_t track = 0;      // MIDI: track index; .sng: BEGINCH block index (0-based, file order)
  uint8_t channel = 0;     // MIDI: channel 0-15; .sng: 0
  bool percussion = false; // a drum hit, not a pitch: General MIDI channel 10, or a channel whose
                           // bank select chose a drum kit (GM2 bank 120, XG bank 127)
};

// The tempo from a point of a song on: where (seconds, and quarter-note beats from the start)
// and how fast (seconds a quarter note).
struct TempoPoint {
  double time_s = 0;
  double beat = 0;
  double s_per_beat = 0.5;
};

// A whole song. Notes are sorted by onset, then track, channel and note.
struct Song {
  std::vector<SongNote> notes;
  double duration_s = 0;              // end of the last note or rest
  uint16_t track_count = 0;           // MIDI: tracks in the file; .sng: BEGINCH blocks
  std::vector<std::string> track_names;  // one per track: its name (MIDI Sequence/Track Name, or
                                         // Instrument Name), printable ASCII; "" when it has none
  std::vector<std::string> warnings;  // things accepted but worth telling the user (file:line: ...)
  std::vector<TempoPoint> tempo;      // tempo map, by time, the first at 0; empty: 120 bpm throughout
};

// Quarter-note beats from the song's start at song time s, and back, through its tempo map.
// Called from: jam following a MIDI clock (player/midi_clock.h), tests.
double song_beat(const Song &song, double s);
double song_seconds(const Song &song, double beat);

// A song file that cannot be read: what() names the file and where (line, or byte offset and
// chunk) and what was expected.
class SongError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Velocity given to every .sng note (the format has none).
constexpr uint8_t kSngVelocity = 100;

// Reads a music2gcode song (.sng) from text; name is used in messages. Called by read_song_file
// and the tests. Throws SongError.
Song read_sng(std::string_view text, const std::string &name);

// Reads a Standard MIDI File (format 0 or 1) from bytes; name is used in messages. Called by
// read_song_file and the tests. Never allocates more than a small multiple of size. Throws
// SongError.
Song read_midi(const uint8_t *data, size_t size, const std::string &name);

// How a tab (.tab) is read: music2gcode's tabs carry neither tempo nor tuning.
struct TabOptions {
  double bpm = 100;         // quarter notes a minute (music2gcode's fixed tempo)
  std::vector<int> tuning;  // MIDI notes of the open strings, low to high; empty: standard_tuning()
};

// Semitones above C of a note name "A".."G" with an optional '#' or 'b'; nullopt otherwise.
// Called by the .sng and MusicXML readers and parse_tuning.
std::optional<int> semitone_of(std::string_view name);

// A tuning as "E2,A2,D3,G3,B3,E4" (six strings, low to high; C4 = MIDI 60) -> MIDI notes.
// Called by the command line (--tuning). Throws SongError naming the bad item.
std::vector<int> parse_tuning(std::string_view text);

// A guitar's standard tuning at its sounding pitch: E2 A2 D3 G3 B3 E4 (music2gcode plays an
// octave higher).
std::vector<int> standard_tuning();

// Reads a plain-text guitar tab (.tab, music2gcode's tab input; tab_reader.cpp says the format)
// from text; name is used in messages ("name:line:column: what"). Each string's notes go to
// their own channel (0 = high E); a chord sounds on every string it names. Called by
// read_song_file and the tests. Throws SongError.
Song read_tab(std::string_view text, const std::string &name, const TabOptions &options = {});

// Reads a MusicXML score (partwise; .musicxml / .xml text, or a compressed .mxl) from bytes;
// name is used in messages ("name: part 'P1' measure 3: what", or the byte offset of bad XML).
// Each part is a track (named by its part name), on the MIDI channel the part names; unpitched
// notes are percussion. Called by read_song_file and the tests. Throws SongError.
Song read_musicxml(const uint8_t *data, size_t size, const std::string &name);

// Largest song file the readers accept, in bytes (a bound on memory, far above real songs).
constexpr size_t kMaxSongFileBytes = 64u << 20;

// Reads a song file, picking the reader by content (MIDI starts with "MThd") or by extension
// (.sng, .tab, .musicxml, .xml, .mxl). Called by the play, render, jam and gcode commands. Throws SongError.
Song read_song_file(const std::string &path, const TabOptions &tab = {});

// Sorts notes by onset (then track, channel, note), sets duration_s to at least the last
// note's end and gives every track a name entry. Called by the readers.
void finish_song(Song &song, double end_s);

// Splits a line into its words (separated by spaces, tabs, CR). Called by the .sng reader and
// the printer preset reader.
std::vector<std::string_view> split_words(std::string_view line);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_SONG_H

// tab_reader.cpp: plain-text guitar tabs (.tab) as music2gcode reads them, with its defects
// mended: two-digit frets, chords on every string that has a fret, technique marks read as the
// plain note (x as a muted string), the tempo and tuning given, errors with line and column.
//
// A tab is a series of systems. A system is six string rows, high E on top, and the rhythm row
// directly above them. A string row starts with a note name and `||` (or `|`), or with `-`,
// and ends with `|`. Above each note column the rhythm row holds its length: W H Q E S T (4, 2,
// 1, 1/2, 1/4, 1/8 beats); `.` dots the event before (x 3/2) and an `L` in a string row ties
// the column's length onto the event before. A column with no fret is a rest. Systems follow
// one another in time. As in music2gcode, the file's first and last lines are not read.
#include <cctype>
#include <string>
#include <vector>

#include "song/song.h"

namespace stepchoir {

namespace {

constexpr size_t kStrings = 6;
constexpr int kMaxFret = 36;

// A line of the file: its text (no line ending) and its 1-based number.
struct Line {
  std::string_view text;
  size_t number;
};

// True for a string row: `-...|`, or a note name (A-G, either case, optional # or b) then `|`.
// Called from: read_tab.
bool string_row(std::string_view s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  if (s.size() < 2 || s.back() != '|') return false;
  if (s[0] == '-') return true;
  const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  if (c < 'A' || c > 'G') return false;
  size_t i = 1;
  if (i < s.size() && (s[i] == '#' || s[i] == 'b')) ++i;
  return i < s.size() && s[i] == '|';
}

// Beats of a rhythm letter, or 0 for none. Called from: read_tab.
double beats_of(char d) {
  switch (d) {
    case 'W': return 4;
    case 'H': return 2;
    case 'Q': return 1;
    case 'E': return 0.5;
    case 'S': return 0.25;
    case 'T': return 0.125;
    default: return 0;
  }
}

}  // namespace

std::vector<int> standard_tuning() { return {40, 45, 50, 55, 59, 64}; }

Song read_tab(std::string_view text, const std::string &name, const TabOptions &options) {
  if (!(options.bpm > 0 && options.bpm <= 1000))
    throw SongError(name + ": tempo " + std::to_string(options.bpm) + " bpm: expected 1 to 1000");
  const std::vector<int> tuning = options.tuning.empty() ? standard_tuning() : options.tuning;
  if (tuning.size() != kStrings) throw SongError(name + ": a tuning names 6 strings, low to high");
  auto fail = [&](size_t line, size_t column, const std::string &what) -> SongError {
    return SongError(name + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + what);
  };
  std::vector<Line> lines;
  for (size_t start = 0, number = 1; start <= text.size(); ++number) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(start, end - start);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    lines.push_back({l, number});
    start = end + 1;
  }
  if (!lines.empty() && lines.back().text.empty()) lines.pop_back();  // the newline at the end
  Song song;
  song.track_count = 1;
  const double seconds_per_beat = 60.0 / options.bpm;
  double now = 0;
  // The event before: its notes' indexes in song.notes (none for a rest) and its length.
  std::vector<size_t> last_notes;
  double last_s = 0;
  bool have_last = false;
  size_t systems = 0;
  for (size_t i = 1; i + 1 < lines.size(); ++i) {
    if (!string_row(lines[i].text)) continue;
    // Six string rows from here, the rhythm row above.
    size_t count = 0;
    while (i + count + 1 < lines.size() && string_row(lines[i + count].text)) ++count;
    if (count != kStrings)
      throw fail(lines[i].number, 1, std::to_string(count) + " string rows together, expected 6 (high E on top)");
    if (i < 2 || string_row(lines[i - 1].text))
      throw fail(lines[i].number, 1, "no rhythm row above the strings (W H Q E S T over each note)");
    const Line &rhythm = lines[i - 1];
    const Line *rows[kStrings];
    size_t width = 0;
    for (size_t s = 0; s < kStrings; ++s) rows[s] = &lines[i + s], width = std::max(width, rows[s]->text.size());
    auto at = [&](size_t s, size_t c) { return c < rows[s]->text.size() ? rows[s]->text[c] : ' '; };
    for (size_t c = 0; c < width; ++c) {
      const char d = c < rhythm.text.size() ? rhythm.text[c] : ' ';
      if (d == ' ' || d == '\t' || d == '|') {
        // A gap, a bar line, or a fret's second digit: any other digit here has no length.
        const char before = c > 0 && c - 1 < rhythm.text.size() ? rhythm.text[c - 1] : ' ';
        const bool second_digit_here = d != '|' && c > 0 && beats_of(before) > 0;
        for (size_t s = 0; s < kStrings; ++s)
          if (std::isdigit(static_cast<unsigned char>(at(s, c))) &&
              !(second_digit_here && std::isdigit(static_cast<unsigned char>(at(s, c - 1)))))
            throw fail(rows[s]->number, c + 1, "a fret under no rhythm letter (W H Q E S T above each note)");
        continue;
      }
      if (d == '.') {
        if (!have_last) throw fail(rhythm.number, c + 1, "a dot before any note or rest");
        for (size_t k : last_notes) song.notes[k].duration_s += last_s / 2;
        now += last_s / 2;
        last_s *= 1.5;
        continue;
      }
      const double beats = beats_of(d);
      if (beats == 0)
        throw fail(rhythm.number, c + 1, std::string("rhythm '") + d + "': expected W H Q E S T (4 to 1/8 beats) or '.'");
      const double length_s = beats * seconds_per_beat;
      bool tie = false;
      for (size_t s = 0; s < kStrings; ++s) tie |= at(s, c) == 'L';
      if (tie) {
        if (!have_last) throw fail(rows[0]->number, c + 1, "a tie (L) before any note or rest");
        for (size_t k : last_notes) song.notes[k].duration_s += length_s;
        last_s += length_s;
        now += length_s;
        continue;
      }
      last_notes.clear();
      for (size_t s = 0; s < kStrings; ++s) {
        if (!std::isdigit(static_cast<unsigned char>(at(s, c)))) continue;  // '-', a mark, x: no note
        int fret = at(s, c) - '0';
        // A second digit in the next column, under no rhythm letter of its own.
        const char next_d = c + 1 < rhythm.text.size() ? rhythm.text[c + 1] : ' ';
        if (std::isdigit(static_cast<unsigned char>(at(s, c + 1))) && (next_d == ' ' || next_d == '\t'))
          fret = fret * 10 + (at(s, c + 1) - '0');
        if (fret > kMaxFret)
          throw fail(rows[s]->number, c + 1, "fret " + std::to_string(fret) + ": above " + std::to_string(kMaxFret));
        const int key = tuning[kStrings - 1 - s] + fret;
        if (key < 0 || key > 127)
          throw fail(rows[s]->number, c + 1, "fret " + std::to_string(fret) + " on this string is beyond MIDI note 127");
        SongNote n;
        n.onset_s = now;
        n.duration_s = length_s;
        n.midi_note = static_cast<uint8_t>(key);
        n.velocity = kSngVelocity;
        n.channel = static_cast<uint8_t>(s);
        last_notes.push_back(song.notes.size());
        song.notes.push_back(n);
      }
      have_last = true;
      last_s = length_s;
      now += length_s;
    }
    ++systems;
    i += kStrings - 1;
  }
  if (systems == 0)
    throw SongError(name + ": no tab system (a rhythm row above six string rows, each ending with '|')");
  if (song.notes.empty()) throw SongError(name + ": no notes: every column is a rest");
  song.tempo = {{0, 0, seconds_per_beat}};
  finish_song(song, now);
  return song;
}

}  // namespace stepchoir

// sng_reader.cpp: the music2gcode song format (.sng) -> Song, strict, errors with file:line.
#include <algorithm>
#include <cmath>
#include <optional>

#include "song/song.h"

namespace stepchoir {

namespace {

// Largest beat count of one note or rest, and the tempo range, in the units of the format:
// bounds that keep every time finite and far above any real song.
constexpr double kMaxBeats = 10000.0;
constexpr double kMinBpm = 1.0;
constexpr double kMaxBpm = 10000.0;

// Parses a plain decimal number "12" or "1.5" (digits before the point required, no sign, no
// exponent, at most 15 digits): the digits as an integer over a power of ten, so 0.3 is the
// double nearest 0.3. Called by read_sng for beats and tempo.
std::optional<double> decimal_of(std::string_view w) {
  size_t i = 0, digits = 0, frac_digits = 0;
  uint64_t mantissa = 0;
  for (; i < w.size() && w[i] >= '0' && w[i] <= '9'; ++i, ++digits) mantissa = mantissa * 10 + (w[i] - '0');
  if (digits == 0) return std::nullopt;
  if (i < w.size() && w[i] == '.') {
    for (++i; i < w.size() && w[i] >= '0' && w[i] <= '9' && digits <= 15; ++i, ++digits, ++frac_digits)
      mantissa = mantissa * 10 + (w[i] - '0');
    if (frac_digits == 0) return std::nullopt;
  }
  if (i != w.size() || digits > 15) return std::nullopt;
  return static_cast<double>(mantissa) / std::pow(10.0, static_cast<double>(frac_digits));
}

// Parses an optionally signed integer of at most 6 digits. Called by read_sng for octaves and
// channel numbers.
std::optional<int> integer_of(std::string_view w) {
  size_t i = 0;
  bool negative = false;
  if (i < w.size() && w[i] == '-') negative = true, ++i;
  if (i == w.size() || w.size() - i > 6) return std::nullopt;
  int v = 0;
  for (; i < w.size(); ++i) {
    if (w[i] < '0' || w[i] > '9') return std::nullopt;
    v = v * 10 + (w[i] - '0');
  }
  return negative ? -v : v;
}

// The parser's state while it walks the lines. Used only by read_sng.
struct SngParser {
  const std::string &name;
  Song song;
  std::optional<double> bpm;
  int tempo_line = 0;
  std::optional<int> declared_channels;
  int channels_line = 0;
  bool in_block = false;
  std::optional<int> block_number;  // the n of "BEGINCH n", if given
  int block_line = 0;
  double block_time_beats = 0;      // position inside the current block
  double end_beats = 0;             // longest block so far
  int line_no = 0;

  // Throws a SongError for the current line. Called by the parse steps.
  [[noreturn]] void fail(const std::string &what) const {
    throw SongError(name + ":" + std::to_string(line_no) + ": " + what);
  }

  // Reads a beat count word. Called by note and rest parsing.
  double beats(std::string_view w) const {
    const auto b = decimal_of(w);
    if (!b) fail("expected a number of beats such as 1, 2 or 0.5, got '" + std::string(w) + "'");
    if (!(*b > 0) || *b > kMaxBeats)
      fail("beats must be above 0 and at most " + std::to_string(static_cast<int>(kMaxBeats)) + ", got '" +
           std::string(w) + "'");
    return *b;
  }

  // Handles one non-empty line's words. Called by read_sng.
  void line(const std::vector<std::string_view> &w) {
    const std::string_view k = w[0];
    if (k == "TEMPO") {
      if (w.size() != 2) fail("expected 'TEMPO <beats per minute>'");
      if (in_block) fail("TEMPO inside a BEGINCH block; put it before the first block");
      if (bpm) fail("second TEMPO (the first is on line " + std::to_string(tempo_line) + "); one tempo per song");
      const auto t = decimal_of(w[1]);
      if (!t || *t < kMinBpm || *t > kMaxBpm) fail("expected a tempo of 1 to 10000 beats per minute, got '" + std::string(w[1]) + "'");
      bpm = *t;
      tempo_line = line_no;
    } else if (k == "CHANNELS") {
      const auto n = w.size() == 2 ? integer_of(w[1]) : std::nullopt;
      if (!n || *n < 1) fail("expected 'CHANNELS <count of 1 or more>'");
      if (declared_channels) fail("second CHANNELS line");
      if (in_block) fail("CHANNELS inside a BEGINCH block; put it before the first block");
      declared_channels = *n;
      channels_line = line_no;
    } else if (k == "BEGINCH") {
      if (in_block) fail("BEGINCH inside the block opened on line " + std::to_string(block_line) + " (missing ENDCH?)");
      if (!bpm) fail("BEGINCH before TEMPO; the song needs 'TEMPO <bpm>' first");
      if (w.size() > 2) fail("expected 'BEGINCH' or 'BEGINCH <channel number>'");
      block_number.reset();
      if (w.size() == 2) {
        const auto n = integer_of(w[1]);
        if (!n || *n < 0) fail("expected a channel number of 0 or more after BEGINCH, got '" + std::string(w[1]) + "'");
        block_number = *n;
      }
      if (song.track_count == UINT16_MAX) fail("too many channel blocks");
      in_block = true;
      block_line = line_no;
      block_time_beats = 0;
    } else if (k == "ENDCH") {
      if (!in_block) fail("ENDCH without a BEGINCH");
      if (w.size() > 2) fail("expected 'ENDCH' or 'ENDCH <channel number>'");
      if (w.size() == 2) {
        const auto n = integer_of(w[1]);
        if (!n || !block_number || *n != *block_number)
          fail("'ENDCH " + std::string(w[1]) + "' closes the block opened on line " + std::to_string(block_line) +
               (block_number ? " as 'BEGINCH " + std::to_string(*block_number) + "'" : std::string(" without a number")));
      }
      in_block = false;
      end_beats = std::max(end_beats, block_time_beats);
      ++song.track_count;
    } else if (k == "-") {
      if (!in_block) fail("rest outside a BEGINCH ... ENDCH block");
      if (w.size() != 2) fail("expected a rest as '- <beats>'");
      block_time_beats += beats(w[1]);
    } else if (semitone_of(k) || (k.size() <= 2 && k[0] >= 'a' && k[0] <= 'g')) {
      const auto semi = semitone_of(k);
      if (!semi)
        fail("note name '" + std::string(k) + "': note names are upper case A to G, with an optional # or b (e.g. 'C#', 'Bb')");
      if (!in_block) fail("note outside a BEGINCH ... ENDCH block");
      if (w.size() != 3) fail("expected a note as '<name> <octave> <beats>', e.g. 'A 4 1'");
      const auto octave = integer_of(w[1]);
      if (!octave) fail("expected an octave number after the note name, got '" + std::string(w[1]) + "'");
      const int midi = 12 * (*octave + 1) + *semi;  // C4 = 60, A4 = 69
      if (*octave < -1 || midi < 0 || midi > 127)
        fail("note " + std::string(k) + " " + std::string(w[1]) + " is outside the MIDI range C -1 to G 9");
      const double b = beats(w[2]);
      SongNote n;
      n.onset_s = block_time_beats * 60.0 / *bpm;
      n.duration_s = b * 60.0 / *bpm;
      n.midi_note = static_cast<uint8_t>(midi);
      n.velocity = kSngVelocity;
      n.track = song.track_count;
      song.notes.push_back(n);
      block_time_beats += b;
    } else {
      fail("unknown line '" + std::string(k) +
           "'; expected TEMPO, CHANNELS, BEGINCH, ENDCH, a note ('A 4 1') or a rest ('- 1')");
    }
  }
};

}  // namespace

Song read_sng(std::string_view text, const std::string &name) {
  SngParser p{name, {}, {}, 0, {}, 0, false, {}, 0, 0, 0, 0};
  size_t pos = text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;  // a UTF-8 byte order mark is not a line
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++p.line_no;
    if (line.find('\0') != std::string_view::npos) p.fail("NUL byte: this is not a text song file");
    line = line.substr(0, line.find('%'));
    const auto w = split_words(line);
    if (!w.empty()) p.line(w);
  }
  if (p.in_block) {
    p.line_no = p.block_line;
    p.fail("BEGINCH without a matching ENDCH before the end of the file");
  }
  if (!p.bpm) throw SongError(name + ": no TEMPO line; a song starts with 'TEMPO <beats per minute>'");
  if (p.song.track_count == 0) throw SongError(name + ": no BEGINCH ... ENDCH block; the song has no channels");
  if (p.song.notes.empty()) throw SongError(name + ": no notes in any channel");
  if (p.declared_channels && *p.declared_channels != p.song.track_count)
    p.song.warnings.push_back(name + ":" + std::to_string(p.channels_line) + ": CHANNELS " +
                              std::to_string(*p.declared_channels) + " but the file has " +
                              std::to_string(p.song.track_count) + " channel blocks; reading all of them");
  p.song.tempo = {{0, 0, 60.0 / *p.bpm}};
  finish_song(p.song, p.end_beats * 60.0 / *p.bpm);
  return std::move(p.song);
}

}  // namespace stepchoir

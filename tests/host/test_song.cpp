// test_song.cpp: the .sng and MIDI file readers: valid files note by note, malformed ones with
// the error they must give, and the sample songs.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "song/song.h"

using namespace stepchoir;

namespace {

// Checks one note of a song. Called by the tests below.
void check_note(const SongNote &n, double onset_s, double duration_s, int midi, int track = 0, int channel = 0) {
  CHECK(n.onset_s == Approx(onset_s).margin(1e-9));
  CHECK(n.duration_s == Approx(duration_s).margin(1e-9));
  CHECK(int{n.midi_note} == midi);
  CHECK(int{n.track} == track);
  CHECK(int{n.channel} == channel);
}

// The message read_sng throws for text, or "" when it reads.
std::string sng_error(const std::string &text) {
  try {
    read_sng(text, "t.sng");
  } catch (const SongError &e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("sng: notes, rests, fractional beats, comments and two channels in absolute seconds") {
  const Song s = read_sng(
      "% a song\n"
      "TEMPO 120 % two beats a second\n"
      "CHANNELS 2\n"
      "\n"
      "BEGINCH 0\n"
      "A 4 1\n"
      "- 0.5\n"
      "C# 5 1.5\n"
      "Bb 3 0.25\n"
      "ENDCH 0\n"
      "BEGINCH\n"
      "\tC  -1  2\r\n"
      "G 9 0.5\n"
      "Cb 4 1\n"
      "B# 3 1\n"
      "ENDCH\n",
      "t.sng");
  REQUIRE(s.notes.size() == 7);
  CHECK(s.track_count == 2);
  CHECK(s.warnings.empty());
  // Sorted by onset, then track.
  check_note(s.notes[0], 0.0, 0.5, 69, 0);
  check_note(s.notes[1], 0.0, 1.0, 0, 1);
  check_note(s.notes[2], 0.75, 0.75, 73, 0);
  check_note(s.notes[3], 1.0, 0.25, 127, 1);
  check_note(s.notes[4], 1.25, 0.5, 59, 1);  // Cb 4 is B 3
  check_note(s.notes[5], 1.5, 0.125, 58, 0);
  check_note(s.notes[6], 1.75, 0.5, 60, 1);  // B# 3 is C 4
  CHECK(s.duration_s == Approx(2.25));
  CHECK(s.notes[0].velocity == kSngVelocity);
}

TEST_CASE("sng: a UTF-8 byte order mark before the first line is skipped") {
  const Song s = read_sng("\xEF\xBB\xBF% song\nTEMPO 60\nBEGINCH\nA 4 1\nENDCH\n", "t.sng");
  CHECK(s.notes.size() == 1);
  CHECK(sng_error("TEMPO 60\n\xEF\xBB\xBF" "BEGINCH\nA 4 1\nENDCH\n").find("t.sng:2: unknown line") == 0);
}

TEST_CASE("sng: beats are exact decimals: 0.1 + 0.2 beats end where 0.3 beats do") {
  const Song s = read_sng("TEMPO 60\nBEGINCH\nA 4 0.1\nA 4 0.2\nB 4 1\nENDCH\nBEGINCH\nC 4 0.3\nD 4 1\nENDCH\n", "t.sng");
  REQUIRE(s.notes.size() == 5);
  CHECK(s.notes[3].onset_s == Approx(0.3).margin(1e-12));
  CHECK(s.notes[4].onset_s == Approx(0.3).margin(1e-12));
  CHECK(s.notes[4].duration_s == 1.0);
  CHECK(sng_error("TEMPO 60\nBEGINCH\nA 4 0.1234567890123456\nENDCH\n").find("t.sng:3: expected a number of beats") == 0);
}

TEST_CASE("sng: a trailing rest counts in the song's length") {
  const Song s = read_sng("TEMPO 60\nBEGINCH\nA 4 1\n- 3\nENDCH\n", "t.sng");
  REQUIRE(s.notes.size() == 1);
  CHECK(s.duration_s == Approx(4.0));
}

TEST_CASE("sng: a CHANNELS line that disagrees is a warning naming its line, and every block is read") {
  const Song s = read_sng("TEMPO 60\nCHANNELS 1\nBEGINCH 0\nA 4 1\nENDCH 0\nBEGINCH 1\nB 4 1\nENDCH 1\n", "t.sng");
  CHECK(s.notes.size() == 2);
  REQUIRE(s.warnings.size() == 1);
  CHECK(s.warnings[0].find("t.sng:2: CHANNELS 1 but the file has 2") == 0);
}

TEST_CASE("sng: malformed input gives file:line and what was expected") {
  struct Case {
    const char *text;
    const char *error;
  };
  const Case cases[] = {
      {"TEMPO 120\nBEGINCH\nc 4 1\nENDCH\n", "t.sng:3: note name 'c': note names are upper case"},
      {"TEMPO 120\nBEGINCH\nA 4 .5\nENDCH\n", "t.sng:3: expected a number of beats such as 1, 2 or 0.5, got '.5'"},
      {"TEMPO 120\nBEGINCH\nA 4 1\nENDCH\nA 4 1\nBEGINCH\nB 4 1\nENDCH\n", "t.sng:5: note outside a BEGINCH"},
      {"TEMPO 120\nBEGINCH\nA 4 1\nhello\nENDCH\n", "t.sng:4: unknown line 'hello'"},
      {"TEMPO 120\nBEGINCH\nA 4 1\n", "t.sng:2: BEGINCH without a matching ENDCH"},
      {"TEMPO 120\nBEGINCH\nBEGINCH\n", "t.sng:3: BEGINCH inside the block opened on line 2"},
      {"TEMPO 120\nENDCH\n", "t.sng:2: ENDCH without a BEGINCH"},
      {"TEMPO 120\nBEGINCH 1\nA 4 1\nENDCH 2\n", "t.sng:4: 'ENDCH 2' closes the block opened on line 2"},
      {"BEGINCH\nA 4 1\nENDCH\n", "t.sng:1: BEGINCH before TEMPO"},
      {"TEMPO fast\n", "t.sng:1: expected a tempo of 1 to 10000"},
      {"TEMPO 0\n", "t.sng:1: expected a tempo of 1 to 10000"},
      {"TEMPO 120\nTEMPO 100\n", "t.sng:2: second TEMPO (the first is on line 1)"},
      {"TEMPO 120\nBEGINCH\nA 4\nENDCH\n", "t.sng:3: expected a note as '<name> <octave> <beats>'"},
      {"TEMPO 120\nBEGINCH\nA 4 1 2\nENDCH\n", "t.sng:3: expected a note as"},
      {"TEMPO 120\nBEGINCH\nA x 1\nENDCH\n", "t.sng:3: expected an octave number"},
      {"TEMPO 120\nBEGINCH\nA 10 1\nENDCH\n", "t.sng:3: note A 10 is outside the MIDI range"},
      {"TEMPO 120\nBEGINCH\nC -2 1\nENDCH\n", "t.sng:3: note C -2 is outside the MIDI range"},
      {"TEMPO 120\nBEGINCH\nA 4 0\nENDCH\n", "t.sng:3: beats must be above 0"},
      {"TEMPO 120\nBEGINCH\nA 4 1e3\nENDCH\n", "t.sng:3: expected a number of beats"},
      {"TEMPO 120\nBEGINCH\nA 4 -1\nENDCH\n", "t.sng:3: expected a number of beats"},
      {"TEMPO 120\nBEGINCH\nA 4 99999\nENDCH\n", "t.sng:3: beats must be above 0 and at most 10000"},
      {"TEMPO 120\nBEGINCH\nA 4 1.\nENDCH\n", "t.sng:3: expected a number of beats"},
      {"TEMPO 120\nBEGINCH\nH 4 1\nENDCH\n", "t.sng:3: unknown line 'H'"},
      {"TEMPO 120\nBEGINCH\nA## 4 1\nENDCH\n", "t.sng:3: unknown line 'A##'"},
      {"TEMPO 120\nBEGINCH\n-\nENDCH\n", "t.sng:3: expected a rest as '- <beats>'"},
      {"TEMPO 120\nBEGINCH\nTEMPO 60\nENDCH\n", "t.sng:3: TEMPO inside a BEGINCH block"},
      {"TEMPO 120\nCHANNELS two\n", "t.sng:2: expected 'CHANNELS <count of 1 or more>'"},
      {"TEMPO 120\nBEGINCH\nENDCH\n", "t.sng: no notes in any channel"},
      {"TEMPO 120\nBEGINCH\n- 1\nENDCH\n", "t.sng: no notes in any channel"},
      {"TEMPO 120\n", "t.sng: no BEGINCH ... ENDCH block"},
      {"% nothing\n", "t.sng: no TEMPO line"},
      {"", "t.sng: no TEMPO line"},
      {"TEMPO 120\nBEGINCH\nA 4 1\0\nENDCH\n", "t.sng:3: NUL byte"},
  };
  for (const auto &c : cases) {
    // Strings with an embedded NUL need their real length.
    const std::string text(c.text, std::char_traits<char>::length(c.text) +
                                       (std::string(c.error).find("NUL") != std::string::npos ? 8 : 0));
    INFO(text);
    const std::string e = sng_error(text);
    CHECK(e.find(c.error) == 0);
    if (e.find(c.error) != 0) WARN("got: " << e);
  }
}

TEST_CASE("sng: the three sample songs read with the lengths their scores give") {
  struct Case {
    const char *file;
    size_t notes;
    uint16_t tracks;
    double beats;
    double bpm;
    size_t warnings;
  };
  // Note counts and the longest channel in beats (rests included), counted from the files with
  // awk: lines matching /^[A-G][#b]? / are notes, the third field (or a rest's second) their beats.
  const Case cases[] = {{"9th.sng", 62, 1, 64, 120, 0}, {"canon.sng", 484, 2, 323.5, 140, 1},
                        {"furelise.sng", 53, 2, 25, 120, 0}};
  for (const auto &c : cases) {
    INFO(c.file);
    const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/" + c.file);
    CHECK(s.notes.size() == c.notes);
    CHECK(s.track_count == c.tracks);
    CHECK(s.duration_s == Approx(c.beats * 60.0 / c.bpm));
    CHECK(s.warnings.size() == c.warnings);
    for (const auto &n : s.notes) CHECK(n.duration_s > 0);
  }
}

TEST_CASE("song files: a file larger than the bound is refused after reading at most the bound") {
  const std::string path = std::string(STEPCHOIR_SCRATCH) + "/huge.mid";
  std::ofstream(path) << "MThd";
  std::filesystem::resize_file(path, kMaxSongFileBytes + 1);  // sparse: no disk used
  try {
    read_song_file(path);
    FAIL("read a file over the bound");
  } catch (const SongError &e) {
    CHECK(std::string(e.what()) == path + ": larger than 64 MiB; not a song file");
  }
  std::filesystem::remove(path);
  CHECK_THROWS_WITH(read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/README.md"),
                    Catch::StartsWith(std::string(STEPCHOIR_SONGS_DIR) + "/README.md: unknown song format"));
}

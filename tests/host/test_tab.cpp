// test_tab.cpp: the guitar tab reader (.tab, music2gcode's tab input): systems in time order,
// rhythm letters, dots and ties, chords on several strings, two-digit frets, technique marks,
// tempo and tuning, and malformed files with line and column.
#include <catch2/catch.hpp>

#include <string>

#include "song/song.h"

using namespace stepchoir;

namespace {

// Two systems between a title line and a last line, both of which the reader skips.
const char *const kTab =
    "Test tab (the first line is not read)\n"
    "   Q  Q  E  E  H     |\n"
    "e||0-----------------|\n"
    "B||---1--------------|\n"
    "G||------2--2--------|\n"
    "D||------------------|\n"
    "A||------------------|\n"
    "E||---------3--3-----|\n"
    "\n"
    "   E  E E .  Q  Q  Q    |\n"
    "e||12--------------4----|\n"
    "B||---5h7---------------|\n"
    "G||----------L--x-------|\n"
    "D||---------------------|\n"
    "A||---------------------|\n"
    "E||-------------------~-|\n"
    "the last line is not read either\n";

void check_note(const SongNote &n, double on, double dur, int midi, int string) {
  INFO("note " << int{n.midi_note} << " at " << n.onset_s);
  CHECK(n.onset_s == Approx(on));
  CHECK(n.duration_s == Approx(dur));
  CHECK(int{n.midi_note} == midi);
  CHECK(int{n.channel} == string);
}

std::string error_of(const std::string &text, const TabOptions &o = {}) {
  try {
    read_tab(text, "t.tab", o);
  } catch (const SongError &e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("tab: rhythm letters, chords, two-digit frets, marks, dots and ties at sounding pitch", "[song]") {
  const Song s = read_tab(kTab, "t.tab");
  REQUIRE(s.notes.size() == 10);
  // 100 bpm: a quarter note is 0.6 s. Standard tuning at sounding pitch: open high E is E4 (64).
  check_note(s.notes[0], 0.0, 0.6, 64, 0);
  check_note(s.notes[1], 0.6, 0.6, 60, 1);  // B string, fret 1
  check_note(s.notes[2], 1.2, 0.3, 57, 2);
  check_note(s.notes[3], 1.5, 0.3, 57, 2);  // a chord: both strings sound
  check_note(s.notes[4], 1.5, 0.3, 43, 5);
  check_note(s.notes[5], 1.8, 1.2, 43, 5);
  // Second system, after the first: fret 12, then 5 h 7 as two plain notes, the 7 dotted and
  // tied on; x is a muted string (a rest); ~ is read as nothing.
  check_note(s.notes[6], 3.0, 0.3, 76, 0);
  check_note(s.notes[7], 3.3, 0.3, 64, 1);
  check_note(s.notes[8], 3.6, 0.3 * 1.5 + 0.6, 66, 1);
  check_note(s.notes[9], 5.25, 0.6, 68, 0);
  CHECK(s.duration_s == Approx(5.85));
  CHECK(s.track_count == 1);
}

TEST_CASE("tab: tempo and tuning are options", "[song]") {
  TabOptions o;
  o.bpm = 120;
  o.tuning = {38, 45, 50, 55, 59, 64};  // drop D
  const Song s = read_tab(kTab, "t.tab", o);
  REQUIRE(s.notes.size() == 10);
  CHECK(s.notes[0].duration_s == Approx(0.5));
  CHECK(int{s.notes[4].midi_note} == 41);  // low string, fret 3, from D2
  CHECK(standard_tuning() == std::vector<int>{40, 45, 50, 55, 59, 64});
}

TEST_CASE("tab: a malformed file names the line and column", "[song]") {
  const std::string strings = "e||0--|\nB||---|\nG||---|\nD||---|\nA||---|\nE||---|\n";
  CHECK(error_of("t\n   Q  |\n" + strings + "end\n") == "");
  CHECK(error_of("t\n   X  |\n" + strings + "end\n") ==
        "t.tab:2:4: rhythm 'X': expected W H Q E S T (4 to 1/8 beats) or '.'");
  CHECK(error_of("t\n   Q  |\ne||0--|\nB||---|\nG||---|\nD||---|\nA||---|\nend\n") ==
        "t.tab:3:1: 5 string rows together, expected 6 (high E on top)");
  CHECK(error_of("t\n" + strings + "end\n") == "t.tab:2:1: no rhythm row above the strings (W H Q E S T over each note)");
  CHECK(error_of("t\n    Q |\ne||0--|\nB||---|\nG||---|\nD||---|\nA||---|\nE||---|\nend\n") ==
        "t.tab:3:4: a fret under no rhythm letter (W H Q E S T above each note)");
  CHECK(error_of("t\n   .  |\n" + strings + "end\n") == "t.tab:2:4: a dot before any note or rest");
  // A second digit under a bar line is no second digit.
  CHECK(error_of("t\n   Q|  |\ne||12---|\nB||-----|\nG||-----|\nD||-----|\nA||-----|\nE||-----|\nend\n") ==
        "t.tab:3:5: a fret under no rhythm letter (W H Q E S T above each note)");
  CHECK(error_of("t\n   Q  |\ne||99-|\nB||---|\nG||---|\nD||---|\nA||---|\nE||---|\nend\n") ==
        "t.tab:3:4: fret 99: above 36");
  CHECK(error_of("just words\nno tab here\n") == "t.tab: no tab system (a rhythm row above six string rows, each ending with '|')");
  CHECK(error_of("t\n   Q  |\ne||---|\nB||---|\nG||---|\nD||---|\nA||---|\nE||---|\nend\n") ==
        "t.tab: no notes: every column is a rest");
  TabOptions o;
  o.tuning = {40, 45};
  CHECK(error_of(kTab, o) == "t.tab: a tuning names 6 strings, low to high");
  o = {};
  o.bpm = 0;
  CHECK(error_of(kTab, o).find("t.tab: tempo 0") == 0);
}

TEST_CASE("tab: a tuning from note names, and a tab file read by its extension", "[song]") {
  CHECK(parse_tuning("E2,A2,D3,G3,B3,E4") == standard_tuning());
  CHECK(parse_tuning("D2,A2,D3,F#3,A3,D4") == std::vector<int>{38, 45, 50, 54, 57, 62});
  CHECK_THROWS_WITH(parse_tuning("E2,A2,D3,G3,B3"), "tuning 'E2,A2,D3,G3,B3': 6 strings, low to high, e.g. E2,A2,D3,G3,B3,E4");
  CHECK_THROWS_WITH(parse_tuning("E2,A2,D3,H3,B3,E4"),
                    "tuning 'E2,A2,D3,H3,B3,E4': 'H3' is not a note such as E2 or F#3 (a name A-G, # or b, an octave 0-9)");
  const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/riff.tab");
  CHECK(s.notes.size() > 20);
  CHECK(s.warnings.empty());
}

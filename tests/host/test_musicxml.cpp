// test_musicxml.cpp: the MusicXML reader: a two-part score with a tempo change, a repeat with
// first and second endings, a tie, a chord, a second voice (backup, forward) and a transposing
// clarinet, as .musicxml and as compressed .mxl; two volta sections in a row; grace and cue
// notes; percussion; malformed files; every score against MuseScore 3's MIDI of it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include "song/song.h"

using namespace stepchoir;

namespace {

Song read_text(const std::string &xml) {
  return read_musicxml(reinterpret_cast<const uint8_t *>(xml.data()), xml.size(), "t.musicxml");
}

std::string error_of(const std::string &xml) {
  try {
    read_text(xml);
  } catch (const SongError &e) {
    return e.what();
  }
  return "";
}

// A one-part score around the measure's contents.
std::string score(const std::string &measure, const std::string &part_list_extra = "") {
  return "<?xml version=\"1.0\"?><score-partwise><part-list><score-part id=\"P1\"><part-name>A</part-name>" +
         part_list_extra + "</score-part></part-list><part id=\"P1\"><measure number=\"1\">" + measure +
         "</measure></part></score-partwise>";
}

}  // namespace

TEST_CASE("musicxml: repeats and voltas, ties, chords, voices, tempo and a transposing part", "[song]") {
  const std::string dir = STEPCHOIR_SONGS_DIR;
  for (const std::string file : {"duet.musicxml", "duet.mxl"}) {
    INFO(file);
    const Song s = read_song_file(dir + "/" + file);
    // Played: measure 1, 2 (first ending), 1, 3 (second ending), 4; 100 bpm, then 50 in bar 4.
    using N = std::tuple<double, double, int, int>;  // onset, length, note, track
    std::vector<N> want = {{0, 0.6, 72, 0},   {0.6, 0.6, 74, 0}, {1.2, 1.8, 76, 0},  // E5 tied into bar 2
                           {3.6, 1.2, 79, 0}, {4.8, 0.6, 72, 0}, {5.4, 0.6, 74, 0}, {6.0, 1.2, 76, 0},
                           {7.2, 2.4, 78, 0}, {9.6, 1.2, 72, 0}, {9.6, 2.4, 79, 0}, {9.6, 2.4, 83, 0},
                           {12.0, 2.4, 84, 0},
                           // The clarinet in Bb sounds a tone below what it reads.
                           {0, 2.4, 60, 1}, {2.4, 2.4, 62, 1}, {4.8, 2.4, 60, 1}, {7.2, 2.4, 63, 1}, {9.6, 4.8, 60, 1}};
    std::vector<N> got;
    for (const SongNote &n : s.notes) got.push_back({n.onset_s, n.duration_s, n.midi_note, n.track});
    std::sort(want.begin(), want.end());
    std::sort(got.begin(), got.end());
    REQUIRE(got.size() == want.size());
    for (size_t i = 0; i < got.size(); ++i) {
      INFO("note " << i << ": " << std::get<2>(want[i]) << " at " << std::get<0>(want[i]));
      CHECK(std::get<0>(got[i]) == Approx(std::get<0>(want[i])));
      CHECK(std::get<1>(got[i]) == Approx(std::get<1>(want[i])));
      CHECK(std::get<2>(got[i]) == std::get<2>(want[i]));
      CHECK(std::get<3>(got[i]) == std::get<3>(want[i]));
    }
    CHECK(s.duration_s == Approx(14.4));
    REQUIRE(s.track_names.size() == 2);
    CHECK(s.track_names[1] == "Clarinet in Bb");
    for (const SongNote &n : s.notes) CHECK(int{n.channel} == n.track);  // the parts' MIDI channels
  }
}

TEST_CASE("musicxml: every score's notes match MuseScore 3's rendering of it", "[song]") {
  // tests/data/songs/reference/NAME.mid is MuseScore 3's MIDI export of tests/data/songs/NAME
  // (tools/render-musicxml-references.sh). The quartet has a flute, a horn in F and a two-staff
  // piano: dotted notes, triplets, accidentals, ties, a chord, voices 1, 2 and 5 with backup and
  // forward, a 4/4 -> 6/8 change with a dotted-quarter metronome mark, a tempo change, a repeat.
  const std::string dir = STEPCHOIR_SONGS_DIR;
  for (const std::string file : {"duet.musicxml", "duet.mxl", "quartet.musicxml"}) {
    INFO(file);
    const Song ours = read_song_file(dir + "/" + file);
    const Song theirs = read_song_file(dir + "/reference/" + file + ".mid");
    using N = std::tuple<double, int, double>;  // onset, note, length
    auto notes = [](const Song &s) {
      std::vector<N> v;
      for (const SongNote &n : s.notes) v.push_back({n.onset_s, n.midi_note, n.duration_s});
      // Onsets of one chord may differ by rounding: sort by onset to the millisecond, note, length.
      std::sort(v.begin(), v.end(), [](const N &a, const N &b) {
        const long ta = std::lround(std::get<0>(a) * 1000), tb = std::lround(std::get<0>(b) * 1000);
        if (ta != tb) return ta < tb;
        return std::get<1>(a) != std::get<1>(b) ? std::get<1>(a) < std::get<1>(b) : std::get<2>(a) < std::get<2>(b);
      });
      return v;
    };
    const std::vector<N> a = notes(ours), b = notes(theirs);
    REQUIRE(a.size() == b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      INFO("note " << i << ": MuseScore plays " << std::get<1>(b[i]) << " at " << std::get<0>(b[i]) << " s for "
                   << std::get<2>(b[i]) << " s");
      CHECK(std::get<1>(a[i]) == std::get<1>(b[i]));
      CHECK(std::get<0>(a[i]) == Approx(std::get<0>(b[i])).margin(0.001));
      double length = std::get<2>(b[i]);
      // The one place the readers differ: the duet's E5 is tied into the first ending. On the
      // second time through, MuseScore still holds it for the first ending's length, over the
      // second ending's F#5; the score plays it to the bar line, as a player would.
      if (file.rfind("duet", 0) == 0 && std::get<1>(b[i]) == 76 && std::get<0>(b[i]) == Approx(6.0)) length -= 0.6;
      // MuseScore ends each note a tick or two (480 a quarter note) before the next one starts.
      CHECK(std::get<2>(a[i]) - length >= 0);
      CHECK(std::get<2>(a[i]) - length <= 0.005);
    }
    CHECK(ours.duration_s == Approx(theirs.duration_s).margin(0.005));
  }
}

TEST_CASE("musicxml: two volta sections in a row, grace notes take no time, cue notes take theirs", "[song]") {
  // Whole notes C D E F G A, played C D C E (first section), F G F A (second), at 120 bpm.
  auto measure = [](int number, const char *step, const std::string &bars) {
    return "<measure number=\"" + std::to_string(number) + "\">" + bars + "<note><pitch><step>" + step +
           "</step><octave>4</octave></pitch><duration>4</duration></note></measure>";
  };
  const std::string fwd = "<barline><repeat direction=\"forward\"/></barline>";
  const std::string end1 = "<barline><ending number=\"1\" type=\"start\"/></barline>"
                           "<barline><ending number=\"1\" type=\"stop\"/><repeat direction=\"backward\"/></barline>";
  const std::string end2 = "<barline><ending number=\"2\" type=\"start\"/></barline>"
                           "<barline><ending number=\"2\" type=\"discontinue\"/></barline>";
  const std::string xml =
      "<score-partwise><part-list><score-part id=\"P1\"/></part-list><part id=\"P1\">"
      "<measure number=\"0\"><attributes><divisions>1</divisions></attributes></measure>" +
      measure(1, "C", fwd) + measure(2, "D", end1) + measure(3, "E", end2) + measure(4, "F", fwd) +
      measure(5, "G", end1) + measure(6, "A", end2) + "</part></score-partwise>";
  const Song s = read_text(xml);
  std::vector<int> keys;
  for (const SongNote &n : s.notes) keys.push_back(n.midi_note);
  CHECK(keys == std::vector<int>{60, 62, 60, 64, 65, 67, 65, 69});
  CHECK(s.notes.back().onset_s == Approx(14));
  const Song g = read_text(score("<attributes><divisions>2</divisions></attributes>"
                                 "<note><grace/><pitch><step>D</step><octave>4</octave></pitch></note>"
                                 "<note><cue/><pitch><step>E</step><octave>4</octave></pitch><duration>2</duration></note>"
                                 "<note><pitch><step>C</step><octave>4</octave></pitch><duration>2</duration></note>"));
  REQUIRE(g.notes.size() == 1);
  CHECK(g.notes[0].onset_s == Approx(0.5));  // after the cue note's quarter
}

TEST_CASE("musicxml: unpitched notes and a channel-10 part are percussion", "[song]") {
  const std::string drums = score(
      "<attributes><divisions>1</divisions></attributes>"
      "<note><unpitched><display-step>C</display-step><display-octave>5</display-octave></unpitched>"
      "<duration>1</duration><instrument id=\"P1-X1\"/></note>"
      "<note><pitch><step>A</step><octave>4</octave></pitch><duration>1</duration></note>",
      "<midi-instrument id=\"P1-X1\"><midi-channel>10</midi-channel><midi-unpitched>39</midi-unpitched></midi-instrument>");
  const Song s = read_text(drums);
  REQUIRE(s.notes.size() == 2);
  CHECK(s.notes[0].percussion);
  CHECK(int{s.notes[0].midi_note} == 38);  // midi-unpitched counts from 1: GM key 38, a snare
  CHECK(s.notes[1].percussion);            // the part plays on channel 10
  CHECK(int{s.notes[1].channel} == kGmDrumChannel);
}

TEST_CASE("musicxml: a malformed score names the file, the element and what was expected", "[song]") {
  const std::string good = "<attributes><divisions>1</divisions></attributes>"
                           "<note><pitch><step>C</step><octave>4</octave></pitch><duration>1</duration></note>";
  CHECK(error_of(score(good)) == "");
  CHECK(error_of("<score-partwise><part") .find("t.musicxml: byte ") == 0);
  CHECK(error_of("<score-partwise><part").find("not well-formed XML") != std::string::npos);
  CHECK(error_of("<score-timewise/>") == "t.musicxml: a timewise score; export the score partwise (every editor's default)");
  CHECK(error_of("<html/>") == "t.musicxml: expected a MusicXML score (<score-partwise>)");
  CHECK(error_of(score("<note><pitch><step>C</step><octave>4</octave></pitch><duration>1</duration></note>")) ==
        "t.musicxml: part 'P1' measure 1: a note before <divisions>");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes>"
                       "<note><pitch><step>H</step><octave>4</octave></pitch><duration>1</duration></note>")) ==
        "t.musicxml: part 'P1' measure 1: pitch step 'H': expected A to G");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes><backup><duration>2</duration></backup>")) ==
        "t.musicxml: part 'P1' measure 1: <backup> goes back before the measure's start");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes><note><duration>1</duration></note>")) ==
        "t.musicxml: part 'P1' measure 1: a note with neither <pitch>, <unpitched> nor <rest>");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes><note><rest/><duration>1</duration></note>")) ==
        "t.musicxml: no notes in any part");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes>"
                       "<note><pitch><step>C</step><octave>2147483647</octave></pitch><duration>1</duration></note>")) ==
        "t.musicxml: part 'P1' measure 1: pitch octave: expected 0 to 9");
  CHECK(error_of(score("<attributes><divisions>1</divisions></attributes>"
                       "<note><pitch><step>C</step><octave>4</octave></pitch><duration>inf</duration></note>")) ==
        "t.musicxml: part 'P1' measure 1: a note without a <duration> of 0 to 10000 quarter notes");
  CHECK(error_of(score("<attributes><divisions>1</divisions><transpose><chromatic>2147483647</chromatic></transpose>"
                       "</attributes>")) == "t.musicxml: part 'P1' measure 1: <transpose> beyond 4 octaves either way");
  CHECK(error_of(score(good + "<barline><repeat direction=\"backward\" times=\"100000\"/></barline>")) ==
        "t.musicxml: part 'P1' measure 1: repeat times 100000: expected 1 to 100");
  const std::string zip = "PK\x03\x04 not really a zip";
  try {
    read_musicxml(reinterpret_cast<const uint8_t *>(zip.data()), zip.size(), "t.mxl");
    FAIL("no error");
  } catch (const SongError &e) {
    CHECK(std::string(e.what()).find("t.mxl: not a valid .mxl (zip) file") == 0);
  }
}

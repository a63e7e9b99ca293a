// test_midi.cpp: the Standard MIDI File reader: tempo map, running status, divisions, skipped
// events, note pairing, and malformed files with the byte offset and chunk of the error.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "smf_builder.h"
#include "song/song.h"

using namespace stepchoir;
using smf::Track;

namespace {

// Reads bytes as t.mid. Called by the tests.
Song read(const smf::Bytes &b) { return read_midi(b.data(), b.size(), "t.mid"); }

// The message read_midi throws for bytes, or "" when it reads. Called by the error table.
std::string error_of(const smf::Bytes &b) {
  try {
    read(b);
  } catch (const SongError &e) {
    return e.what();
  }
  return "";
}

// Checks a note's timing, pitch and origin. Called by the tests.
void check_note(const SongNote &n, double onset_s, double duration_s, int midi, int track, int channel) {
  CHECK(n.onset_s == Approx(onset_s).margin(1e-9));
  CHECK(n.duration_s == Approx(duration_s).margin(1e-9));
  CHECK(int{n.midi_note} == midi);
  CHECK(int{n.track} == track);
  CHECK(int{n.channel} == channel);
}

}  // namespace

TEST_CASE("midi: every tempo change of the map applies from its tick on") {
  // 480 ticks a quarter; 120 bpm, then 240 bpm at tick 480, then 60 bpm at tick 960.
  Track t;
  t.tempo(0, 500000).ev(0, {0x90, 60, 100}).ev(480, {0x80, 60, 0});
  t.tempo(0, 250000).ev(0, {0x90, 62, 90}).ev(480, {0x80, 62, 0});
  t.tempo(0, 1000000).ev(0, {0x90, 64, 80}).ev(240, {0x80, 64, 0}).end(240);
  const Song s = read(smf::file(0, 480, {t}));
  REQUIRE(s.notes.size() == 3);
  check_note(s.notes[0], 0.0, 0.5, 60, 0, 0);
  check_note(s.notes[1], 0.5, 0.25, 62, 0, 0);
  check_note(s.notes[2], 0.75, 0.5, 64, 0, 0);
  CHECK(int{s.notes[1].velocity} == 90);
  CHECK(s.duration_s == Approx(1.75));  // End of Track 240 ticks after the last note-off
}

TEST_CASE("midi: without a Set Tempo the tempo is 120 bpm") {
  Track t;
  t.ev(96, {0x91, 69, 1}).ev(96, {0x81, 69, 64}).end();
  const Song s = read(smf::file(0, 96, {t}));
  REQUIRE(s.notes.size() == 1);
  check_note(s.notes[0], 0.5, 0.5, 69, 0, 1);
}

TEST_CASE("midi: running status, note-on with velocity 0 as note-off") {
  Track t;
  t.ev(0, {0x90, 60, 100}).ev(100, {60, 0}).ev(0, {62, 100}).ev(100, {62, 0}).ev(0, {0xC0, 5}).ev(0, {0x90, 64, 1});
  t.ev(100, {0xB0, 7, 100}).ev(0, {10, 64}).ev(0, {0x80, 64, 0}).end();
  const Song s = read(smf::file(0, 100, {t}));
  REQUIRE(s.notes.size() == 3);
  check_note(s.notes[0], 0.0, 0.5, 60, 0, 0);
  check_note(s.notes[1], 0.5, 0.5, 62, 0, 0);
  check_note(s.notes[2], 1.0, 0.5, 64, 0, 0);
  CHECK(s.warnings.empty());
}

TEST_CASE("midi: format 1, the tempo track's map applies to every track") {
  Track tempo, a, b;
  tempo.tempo(0, 600000).tempo(960, 300000).end();
  a.ev(0, {0x92, 48, 70}).ev(1920, {0x82, 48, 0}).end();  // 0.6 s + 0.3 s
  b.ev(960, {0x99, 36, 127}).ev(0, {0x89, 36, 0}).ev(0, {0x99, 38, 127}).ev(480, {0x89, 38, 0}).end();
  const Song s = read(smf::file(1, 960, {tempo, a, b}));
  CHECK(s.track_count == 3);
  REQUIRE(s.notes.size() == 2);  // the zero-length note 36 is dropped, with a warning
  check_note(s.notes[0], 0.0, 0.9, 48, 1, 2);
  check_note(s.notes[1], 0.6, 0.15, 38, 2, 9);
  REQUIRE(s.warnings.size() == 1);
  CHECK(s.warnings[0] == "t.mid: 1 notes of zero length (dropped)");
}

TEST_CASE("midi: SMPTE division counts ticks in frames and ignores tempo") {
  // 25 frames a second, 40 ticks a frame: 1000 ticks a second. 0xE7 is -25.
  Track t;
  t.tempo(0, 250000).ev(500, {0x90, 57, 100}).ev(1000, {0x80, 57, 0}).end();
  const Song s = read(smf::file(0, 0xE728, {t}));
  REQUIRE(s.notes.size() == 1);
  check_note(s.notes[0], 0.5, 1.0, 57, 0, 0);
  // 29.97 drop-frame: 30 ticks a frame, 0xE3 is -29.
  Track u;
  u.ev(0, {0x90, 57, 100}).ev(2997, {0x80, 57, 0}).end();
  const Song d = read(smf::file(0, 0xE31E, {u}));
  REQUIRE(d.notes.size() == 1);
  CHECK(d.notes[0].duration_s == Approx(2997.0 / (30 * 30000.0 / 1001.0)));
}

TEST_CASE("midi: meta events, sysex, pressure and bend are skipped, and running status survives none of them") {
  Track t;
  t.ev(0, {0xFF, 0x03, 5, 'p', 'i', 'a', 'n', 'o'});           // track name
  t.ev(0, {0xF0, 4, 0x7E, 0x7F, 0x09, 0xF7});                     // GM on
  t.ev(0, {0xF7, 2, 0x01, 0x02});                                  // sysex escape
  t.ev(0, {0xFF, 0x7F, 3, 0x00, 0x00, 0x41});                      // sequencer specific
  t.ev(0, {0xFF, 0x58, 4, 4, 2, 24, 8});                           // time signature
  t.ev(0, {0x90, 60, 100}).ev(0, {0xA0, 60, 50}).ev(0, {0xD0, 40}).ev(0, {0xE0, 0, 64});
  t.ev(50, {0x80, 60, 0}).end();
  const Song s = read(smf::file(0, 100, {t}));
  REQUIRE(s.notes.size() == 1);
  check_note(s.notes[0], 0.0, 0.25, 60, 0, 0);
  Track bad;
  bad.ev(0, {0x90, 60, 100}).ev(0, {0xFF, 0x01, 1, 'x'}).ev(10, {60, 0}).end();
  CHECK(error_of(smf::file(0, 100, {bad})).find("data byte 0x3C without a running status") != std::string::npos);
}

TEST_CASE("midi: overlapping notes of one pitch end first in, first out") {
  Track t;
  t.ev(0, {0x90, 60, 100}).ev(100, {0x90, 60, 90}).ev(100, {0x80, 60, 0}).ev(100, {0x80, 60, 0}).end();
  const Song s = read(smf::file(0, 100, {t}));
  REQUIRE(s.notes.size() == 2);
  check_note(s.notes[0], 0.0, 1.0, 60, 0, 0);
  check_note(s.notes[1], 0.5, 1.0, 60, 0, 0);
  CHECK(int{s.notes[1].velocity} == 90);
}

TEST_CASE("midi: notes left sounding end at End of Track, stray note-offs and unknown chunks are warnings") {
  Track t;
  t.ev(0, {0x80, 50, 0}).ev(0, {0x90, 61, 100}).end(200);
  smf::Bytes f = smf::file(0, 100, {t});
  smf::chunk(f, "XFIH", {1, 2, 3});
  const Song s = read(f);
  REQUIRE(s.notes.size() == 1);
  check_note(s.notes[0], 0.0, 1.0, 61, 0, 0);
  REQUIRE(s.warnings.size() == 3);
  CHECK(s.warnings[0] == "t.mid: 1 notes still sounding at End of Track (ended there)");
  CHECK(s.warnings[1] == "t.mid: 1 note-offs without a sounding note (ignored)");
  CHECK(s.warnings[2] == "t.mid: 1 chunks of unknown type (skipped)");
}

TEST_CASE("midi: malformed files give the byte offset, the chunk and what is wrong") {
  Track ok;
  ok.ev(0, {0x90, 60, 100}).ev(10, {0x80, 60, 0}).end();
  const smf::Bytes good = smf::file(0, 100, {ok});
  // Byte 14 is the MTrk chunk's header, 22 its first event.
  auto with_track = [](std::initializer_list<uint8_t> body) {
    Track t;
    t.bytes = body;
    return smf::file(0, 100, {t});
  };
  auto patched = [&](size_t at, std::initializer_list<uint8_t> b) {
    smf::Bytes f = good;
    std::copy(b.begin(), b.end(), f.begin() + static_cast<long>(at));
    return f;
  };
  smf::Bytes truncated = good;
  truncated.resize(good.size() - 3);
  smf::Bytes trailing = good;
  trailing.push_back('M');
  trailing.push_back('T');
  smf::Bytes extra_track = good;
  smf::chunk(extra_track, "MTrk", ok.bytes);
  struct Case {
    smf::Bytes bytes;
    std::string error;
  };
  const std::vector<Case> cases = {
      {{}, "t.mid: byte 0: expected a MIDI file"},
      {{'M', 'T', 'h', 'd', 0, 0, 0, 6, 0, 0, 0, 1}, "t.mid: byte 0: expected a MIDI file"},
      {patched(4, {0, 0, 0, 5}), "t.mid: byte 4: header length 5, expected 6"},
      {patched(4, {0xFF, 0xFF, 0xFF, 0xFF}), "t.mid: byte 4: header length 4294967295 runs past the end"},
      {patched(8, {0, 2}), "t.mid: byte 8: format 2 (independent sequences) is not supported"},
      {patched(8, {0, 7}), "t.mid: byte 8: unknown format 7"},
      {patched(10, {0, 0}), "t.mid: byte 10: the header declares no tracks"},
      {patched(10, {0, 2}), "t.mid: byte 10: format 0 has one track, the header declares 2"},
      {patched(8, {0, 1, 0, 2}), "t.mid: byte 34: the header declares 2 tracks but the file has 1"},
      {patched(12, {0, 0}), "t.mid: byte 12: division of 0 ticks per quarter note"},
      {patched(12, {0xE9, 10}), "t.mid: byte 12: SMPTE division with 23 frames per second"},
      {patched(12, {0xE8, 0}), "t.mid: byte 12: SMPTE division with 0 ticks per frame"},
      {patched(18, {0xFF, 0xFF, 0xFF, 0xFF}),
       "t.mid: byte 22 (chunk 1 'MTrk' at byte 14, track 0): chunk length 4294967295 runs past the end of the file "
       "(12 bytes left)"},
      {truncated, "t.mid: byte 22 (chunk 1 'MTrk' at byte 14, track 0): chunk length 12 runs past the end of the file (9 bytes left)"},
      {trailing, "t.mid: byte 34 (chunk 2 at byte 34): truncated chunk header (2 bytes left, 8 needed)"},
      {with_track({}), "t.mid: byte 22 (chunk 1 'MTrk' at byte 14, track 0): track ends without an End of Track"},
      {with_track({0x00, 0x90, 60, 100}), "t.mid: byte 26 (chunk 1 'MTrk' at byte 14, track 0): track ends without"},
      {with_track({0x00, 0x90, 60, 100, 0x00, 0xF8}),
       "t.mid: byte 27 (chunk 1 'MTrk' at byte 14, track 0): status byte 0xF8 is not allowed in a MIDI file"},
      {with_track({0x00, 0x3C, 100}), "t.mid: byte 23 (chunk 1 'MTrk' at byte 14, track 0): data byte 0x3C without"},
      {with_track({0x00, 0x90, 60}), "t.mid: byte 25 (chunk 1 'MTrk' at byte 14, track 0): channel message cut off"},
      {with_track({0x00, 0x90, 60, 0x80, 0x00}), "t.mid: byte 25 (chunk 1 'MTrk' at byte 14, track 0): expected a data "
                                                 "byte (0-127), got status byte 0x80"},
      {with_track({0x81, 0x80, 0x80, 0x80, 0x00, 0x90, 60, 100}),
       "t.mid: byte 22 (chunk 1 'MTrk' at byte 14, track 0): variable-length number longer than 4 bytes"},
      {with_track({0x81, 0x80}), "t.mid: byte 22 (chunk 1 'MTrk' at byte 14, track 0): variable-length number runs past"},
      {with_track({0x00, 0xFF, 0x01, 0x8F, 0xFF, 0xFF, 0x7F}),
       "t.mid: byte 29 (chunk 1 'MTrk' at byte 14, track 0): meta event length 33554431 runs past the end of the track"},
      {with_track({0x00, 0xF0, 0x7F, 0x01}), "t.mid: byte 25 (chunk 1 'MTrk' at byte 14, track 0): sysex length 127 runs"},
      {with_track({0x00, 0xFF, 0x51, 0x02, 0x07, 0xA1, 0x00, 0xFF, 0x2F, 0x00}),
       "t.mid: byte 23 (chunk 1 'MTrk' at byte 14, track 0): Set Tempo with length 2, expected 3"},
      {with_track({0x00, 0xFF, 0x51, 0x03, 0, 0, 0, 0x00, 0xFF, 0x2F, 0x00}),
       "t.mid: byte 23 (chunk 1 'MTrk' at byte 14, track 0): Set Tempo of 0 microseconds"},
      {with_track({0x00, 0xFF, 0x2F, 0x00, 0x00}),
       "t.mid: byte 26 (chunk 1 'MTrk' at byte 14, track 0): 1 bytes after End of Track"},
      {with_track({0x00, 0xFF, 0x2F, 0x01, 0x00}),
       "t.mid: byte 23 (chunk 1 'MTrk' at byte 14, track 0): End of Track with length 1, expected 0"},
      {with_track({0x00, 0xFF}), "t.mid: byte 24 (chunk 1 'MTrk' at byte 14, track 0): meta event cut off after 0xFF"},
      {with_track({0x00, 0xFF, 0x2F, 0x00}), "t.mid: no notes in any track"},
      {extra_track, "t.mid: byte 42 (chunk 2 'MTrk' at byte 34, track 1): more MTrk chunks than the 1 the header"},
  };
  CHECK(error_of(good).empty());
  for (size_t i = 0; i < cases.size(); ++i) {
    INFO("case " << i << ": expected " << cases[i].error);
    const std::string e = error_of(cases[i].bytes);
    INFO("got " << e);
    CHECK(e.find(cases[i].error) == 0);
  }
}

TEST_CASE("midi: an absurd header track count with a short file is an error, not a large allocation") {
  smf::Bytes f = {'M', 'T', 'h', 'd', 0, 0, 0, 6, 0, 1, 0xFF, 0xFF, 0, 96};
  CHECK(error_of(f) == "t.mid: byte 14: the header declares 65535 tracks but the file has 0");
}

TEST_CASE("midi: drum hits by channel 10 and by bank select, and track names") {
  Track tempo, a, b;
  // Track 0 is named by its Sequence/Track Name, track 1 by its Instrument Name alone.
  tempo.ev(0, {0xFF, 0x03, 4, 'S', 'o', 'n', 'g'}).end();
  a.ev(0, {0xFF, 0x04, 7, ' ', 'L', 'e', 'a', 'd', ' ', 0x01});
  a.ev(0, {0x99, 36, 100}).ev(100, {0x89, 36, 0});  // channel 10: a kick
  a.ev(0, {0x92, 60, 100}).ev(100, {0x82, 60, 0});  // channel 3: a pitch
  // GM2: bank 120 then a program change makes channel 3 a drum kit; bank 121 makes channel 10
  // melodic. A bank select alone changes nothing until the program change.
  a.ev(0, {0xB2, 0, 120}).ev(0, {0x92, 62, 100}).ev(100, {0x82, 62, 0});
  a.ev(0, {0xC2, 0}).ev(0, {0x92, 38, 100}).ev(100, {0x82, 38, 0});
  a.ev(0, {0xB9, 0, 121}).ev(0, {0xC9, 0}).ev(0, {0x99, 64, 100}).ev(100, {0x89, 64, 0}).end();
  const Song s = read(smf::file(1, 100, {tempo, a}));
  REQUIRE(s.notes.size() == 5);
  CHECK(s.notes[0].percussion);        // channel 10
  CHECK_FALSE(s.notes[1].percussion);  // channel 3
  CHECK_FALSE(s.notes[2].percussion);  // bank chosen, no program change yet
  CHECK(s.notes[3].percussion);        // GM2 rhythm bank
  CHECK_FALSE(s.notes[4].percussion);  // GM2 melody bank on channel 10
  REQUIRE(s.track_names.size() == 2);
  CHECK(s.track_names[0] == "Song");
  CHECK(s.track_names[1] == "Lead");  // trimmed, the control byte left out
}

// test_gcode.cpp: G-code export: printer presets, and songs (samples, generated, MIDI) planned,
// written, decoded back and checked against the score; one test for each defect of the original.
#include <catch2/catch.hpp>

#include <random>
#include <string>
#include <vector>

#include "../fuzz/fuzz_plan.h"
#include "gcode_check.h"
#include "smf_builder.h"
#include "song/gcode.h"
#include "song/song.h"

using namespace stepchoir;
using gcheck::box;
using gcheck::round_trip;
using gcheck::song_of;
using gcheck::random_song;

namespace {

// The message plan_gcode throws, or "".
std::string plan_error(const Song &song, const Printer &printer, const GcodeOptions &o = {}) {
  try {
    plan_gcode(song, printer, o);
  } catch (const GcodeError &e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("gcode: the built-in presets: Ender-3, Prusa MK3S, Voron 2.4, Prusa Core One and Kossel likes, and a "
          "generic printer") {
  const auto &p = builtin_printers();
  REQUIRE(p.size() == 6);
  const Printer &e = find_printer(p, "ender3");
  CHECK(e.axes[0].steps_per_mm == 80);
  CHECK(e.axes[2].steps_per_mm == 400);
  CHECK(e.axes[1].max_mm == 220);
  CHECK(e.axes[2].max_feed_mm_s == 5);
  CHECK(e.axes[kExtruderAxis].steps_per_mm == 93);
  CHECK(e.axes[kExtruderAxis].min_mm == -kExtruderTravelMm);
  const Printer &m = find_printer(p, "prusa-mk3s");
  CHECK(m.axes[0].steps_per_mm == 100);
  CHECK(m.axes[1].min_mm == -4);
  CHECK(m.description.find("Prusa-MK3S-like") == 0);
  CHECK(m.kinematics == Kinematics::kCartesian);
  const Printer &v = find_printer(p, "voron24");
  CHECK(v.kinematics == Kinematics::kCoreXY);
  CHECK(v.axes[0].steps_per_mm == 160);  // motor A: 200 full steps x 32 / 40 mm
  CHECK(v.axes[2].steps_per_mm == 800);
  CHECK(v.axes[0].max_mm == 350);
  CHECK(v.description.find("Voron-2.4-like") == 0);  // the kinematics word is not part of it
  CHECK(find_printer(p, "prusa-core-one").kinematics == Kinematics::kCoreXY);
  CHECK(find_printer(p, "generic").kinematics == Kinematics::kCartesian);
  const Printer &k = find_printer(p, "kossel");
  CHECK(k.kinematics == Kinematics::kDelta);
  CHECK(k.delta_rod_mm == 267);
  CHECK(k.delta_printable_mm == 115);
  CHECK_THROWS_WITH(find_printer(p, "mk4"),
                    "no printer named 'mk4'; known: ender3, prusa-mk3s, voron24, prusa-core-one, kossel, generic");
}

TEST_CASE("gcode: bad printer descriptions say where and what") {
  const std::pair<const char *, const char *> cases[] = {
      {"a 80,80 0:1,0:1,0:1 1,1,1", "p.conf:1: expected steps/mm as X,Y,Z or X,Y,Z,E, got '80,80'"},
      {"a 80,80,80,-1 0:9,0:9,0:9 1,1,1", "p.conf:1: E steps/mm must be 0 to 1000000"},
      {"a 80,80,80,80 0:9,0:9,0:9 1,1,1,-2", "p.conf:1: E's max feed is negative"},
      {"# c\na 80,80,x 0:9,0:9,0:9 1,1,1", "p.conf:2: expected a number for steps/mm, got 'x'"},
      {"a 80,80,80 0:9,0:9 1,1,1", "p.conf:1: expected the volume as XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX"},
      {"a 80,80,80 0:9,0:9,9 1,1,1", "p.conf:1: expected Z's range as MIN:MAX, got '9'"},
      {"a 80,80,80 0:9,5:5.5,0:9 1,1,1", "p.conf:1: Y's range 5:5.5 is shorter than 1 mm"},
      {"a 0,80,80 0:9,0:9,0:9 1,1,1", "p.conf:1: X steps/mm must be above 0"},
      {"a 80,80,80 0:9,0:9,0:9 1,-1,1", "p.conf:1: Y's max feed is negative"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,nan", "p.conf:1: expected a number for max feed (mm/s), got 'nan'"},
      {"a 80,80,80 0:9,0:9,0:9", "p.conf:1: expected 'name steps/mm volume max-feed description'"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1\na 80,80,80 0:9,0:9,0:9 1,1,1", "p.conf:2: a second printer named 'a'"},
      {"# nothing\n", "p.conf: no printers"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 kinematics=scara", "p.conf:1: kinematics 'scara': expected cartesian, corexy or delta"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 kinematics=delta rod=200", "p.conf:1: printer a (delta): needs rod=, radius= and printable="},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 kinematics=delta rod=200 radius=90 printable=100",
       "p.conf:1: printer a (delta): printable radius 100.0 mm reaches the towers (radius 90.0 mm)"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 kinematics=delta rod=200 radius=120 printable=100",
       "p.conf:1: printer a (delta): rods of 200.0 mm cannot reach the edge of the printable radius"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 colour=red", "p.conf:1: unknown key 'colour'"},
      {"a 80,80,80 0:9,0:9,0:9 1,1,1 accel=900:500", "p.conf:1: accel 900:500: both above 0, the safe figure at least"},
  };
  for (const auto &[text, error] : cases) {
    INFO(text);
    CHECK_THROWS_WITH(parse_printers(text, "p.conf"), Catch::StartsWith(error));
  }
}

TEST_CASE("gcode: the sample songs on every preset: rates, times, volume, directions, last note") {
  for (const char *file : {"9th.sng", "canon.sng", "furelise.sng"})
    for (const auto &printer : builtin_printers()) {
      INFO(file << " on " << printer.name);
      const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/" + file);
      GcodeOptions o;
      o.fold_octaves = true;  // canon's F#6 is above a Z axis's max feed on every preset
      const auto d = round_trip(s, printer, o);
      CHECK(d.millimetres);
      CHECK(d.absolute);
      CHECK_FALSE(d.homed);
    }
}

TEST_CASE("gcode: generated songs with rests, chords and three voices, on small and large volumes") {
  std::mt19937 rng(12345);
  for (int round = 0; round < 40; ++round) {
    INFO("round " << round);
    const Song s = random_song(rng, 1 + round % 3);
    GcodeOptions o;
    o.steps_per_cycle = round % 2 ? 2.0 : 1.0;
    o.home = round % 5 == 0;
    round_trip(s, round % 4 == 0 ? box(3, 5, 2) : find_printer(builtin_printers(), "generic"), o);
  }
}

TEST_CASE("gcode: a two-track MIDI file with tempo changes") {
  smf::Track tempo, a, b;
  tempo.tempo(0, 500000).tempo(960, 400000).tempo(960, 700000).end();
  for (int k = 0; k < 12; ++k) a.ev(k == 0 ? 0 : 60, {0x90, static_cast<uint8_t>(60 + k), 90}).ev(180, {0x80, static_cast<uint8_t>(60 + k), 0});
  a.end();
  b.ev(0, {0x91, 48, 80}).ev(1440, {0x81, 48, 0}).ev(0, {0x91, 43, 80}).ev(480, {0x81, 43, 0}).end();
  const smf::Bytes f = smf::file(1, 480, {tempo, a, b});
  const Song s = read_midi(f.data(), f.size(), "t.mid");
  const GcodePlan plan = plan_gcode(s, find_printer(builtin_printers(), "ender3"), {});
  REQUIRE(plan.axis_voice.size() == 2);
  CHECK(plan.axis_voice[0].track == 1);
  CHECK(plan.axis_voice[1].channel == 1);
  round_trip(s, find_printer(builtin_printers(), "ender3"));
}

TEST_CASE("gcode: defect fixed: the room is measured toward the border the move heads for") {
  // X is 0-100 and starts at 50. A4 at 2 steps a cycle on 80 steps/mm runs 11 mm/s: 3 s take X
  // up to 83 mm. The next note has 83 mm of room down and 17 mm up: 5 s (55 mm) go down in one
  // move to 28 mm. (The original measured the 17 mm to the nearer border and split the move.)
  const Song s = song_of({{0, 0, 3, 69}, {0, 3, 5, 69}});
  const Printer p = box(100, 100, 100);
  const auto d = round_trip(s, p);
  REQUIRE(d.moves.size() == 2);
  CHECK(d.moves[0].to[0] == Approx(50 + 11 * 3).margin(1e-4));
  CHECK(d.moves[1].to[0] == Approx(50 + 11 * 3 - 11 * 5).margin(1e-4));
}

TEST_CASE("gcode: defect fixed: a move longer than the axis bounces until it ends") {
  // 60 s of A5 (22 mm/s) on a 5 mm X: 1320 mm, some 264 reversals, all inside 0-5 mm.
  const Song s = song_of({{0, 0, 60, 81}});
  const auto d = round_trip(s, box(5, 5, 5));
  CHECK(d.moves.size() >= 264);
  CHECK(d.moves.size() <= 266);
  double travelled = 0;
  for (const auto &m : d.moves) travelled += std::fabs(m.to[0] - m.from[0]);
  CHECK(travelled == Approx(note_hz(81) * 2 / 80 * 60).epsilon(1e-6));
}

TEST_CASE("gcode: a song that would need more moves than the bound is refused before any is made") {
  // A day of A5 on a 5 mm axis: 22 mm/s x 86400 s / 5 mm = 380,000 reversals fit; ten days do not.
  CHECK(plan_error(song_of({{0, 0, 86400, 81}}), box(5, 5, 5)).empty());
  CHECK(plan_error(song_of({{0, 0, 864000, 81}}), box(5, 5, 5)).find("the song would take some 38") == 0);
}

TEST_CASE("gcode: defect fixed: the last note is played, to its end") {
  const Song s = song_of({{0, 0, 1, 60}, {0, 1, 0.5, 72}});
  const GcodePlan plan = plan_gcode(s, box(200, 200, 200), {});
  REQUIRE(plan.segments.size() == 2);
  CHECK(plan.segments.back().midi_note[0] == 72);
  CHECK(plan.duration_s == 1.5);
  const auto d = round_trip(s, box(200, 200, 200));
  CHECK(d.end_s == Approx(1.5).margin(1e-6));
}

TEST_CASE("gcode: defect fixed: more voices than axes are refused with the list, or chosen with --channels") {
  const Song s = song_of({{0, 0, 1, 60}, {1, 0, 1, 62}, {2, 0, 1, 64}, {3, 0, 1, 65}});
  const std::string e = plan_error(s, box(100, 100, 100));
  CHECK(e.find("the song has 4 voices and the printer 3 axes; choose up to 3 with --channels") == 0);
  CHECK(e.find("\n  3: track 3 channel 0 (1 notes)") != std::string::npos);
  GcodeOptions o;
  o.voice_of_axis = {3, 1};
  const GcodePlan plan = plan_gcode(s, box(100, 100, 100), o);
  REQUIRE(plan.axis_voice.size() == 2);
  CHECK(plan.axis_voice[0].track == 3);
  CHECK(plan.segments[0].midi_note[0] == 65);
  CHECK(plan.segments[0].midi_note[1] == 62);
  CHECK(plan.segments[0].midi_note[2] == -1);
  round_trip(s, box(100, 100, 100), o);
  o.voice_of_axis = {0, 4};
  CHECK(plan_error(s, box(100, 100, 100), o) == "--channels: no voice 4; the song has voices 0-3");
  o.voice_of_axis = {1, 1};
  CHECK(plan_error(s, box(100, 100, 100), o) == "--channels: voice 1 given twice");
  o.voice_of_axis = {0, 1, 2, 3};
  CHECK(plan_error(s, box(100, 100, 100), o).find("--channels names 4 voices") == 0);
}

TEST_CASE("gcode: defect fixed: rests are silence: a resting axis stays still, all resting dwells") {
  const Song s = song_of({{0, 0, 1, 60}, {1, 0.5, 1, 64}, {0, 2.25, 1, 67}});
  const auto d = round_trip(s, box(100, 100, 100));  // check(): resting axes do not move
  // 1.5 s to 2.25 s nothing sounds: one G4 of 750 ms.
  size_t dwells = 0;
  for (const auto &m : d.moves)
    if (m.dwell) {
      ++dwells;
      CHECK(m.start_s == Approx(1.5).margin(1e-9));
      CHECK(m.duration_s == Approx(0.75));
    }
  CHECK(dwells == 1);
}

TEST_CASE("gcode: notes too fast for an axis are named, or folded by octaves") {
  // Z on an Ender-3: 400 steps/mm, 5 mm/s: above 1000 Hz at 2 steps a cycle (B5 = 988 Hz fits,
  // C6 = 1047 Hz does not).
  const Printer &e = find_printer(builtin_printers(), "ender3");
  GcodeOptions o;
  const Song z = song_of({{0, 0, 1, 50}, {1, 0, 1, 50}, {2, 0, 0.5, 83}, {2, 0.5, 0.5, 84}, {2, 1, 0.5, 90}, {2, 1.5, 0.5, 84}});
  const GcodePlan warned = plan_gcode(z, e, o);
  REQUIRE(warned.warnings.size() == 1);
  CHECK(warned.warnings[0].find("Z: C6 (x2), F#6 need more than the max feed of 5.0 mm/s; kept") == 0);
  round_trip(z, e, o);  // kept at pitch: the rates are still the notes'
  o.fold_octaves = true;
  const GcodePlan folded = plan_gcode(z, e, o);
  REQUIRE(folded.warnings.size() == 1);
  CHECK(folded.warnings[0].find("played octaves lower") != std::string::npos);
  CHECK(folded.segments[1].midi_note[2] == 72);
  CHECK(folded.segments[2].midi_note[2] == 78);
  round_trip(z, e, o);  // check() expects the folded notes' rates
}

TEST_CASE("gcode: chords in one voice: the highest note plays, notes never heard are counted") {
  const Song s = song_of({{0, 0, 2, 60}, {0, 0, 1, 64}, {0, 0.5, 0.25, 55}});
  const GcodePlan plan = plan_gcode(s, box(100, 100, 100), {});
  REQUIRE(plan.warnings.size() == 1);
  CHECK(plan.warnings[0] == "X: 1 notes of the voice are never heard: an axis plays one note at a time, the highest");
  REQUIRE(plan.segments.size() == 4);
  CHECK(plan.segments[0].midi_note[0] == 64);
  CHECK(plan.segments[3].midi_note[0] == 60);
  round_trip(s, box(100, 100, 100));
}

TEST_CASE("gcode: header and footer: units, absolute positions, optional homing, G1 on request") {
  const Song s = song_of({{0, 0, 1, 60}});
  GcodeOptions o;
  o.home = true;
  o.use_g1 = true;
  const std::string text = write_gcode(plan_gcode(s, box(100, 100, 100), o), box(100, 100, 100), o, "song");
  CHECK(text.find("G21 ; millimetres\nG90 ; absolute positions\n") != std::string::npos);
  CHECK(text.find("G28 ; home every axis\nG1 Z50.00000 F3000.000 ; to the middle of the volume\nG1 X50.00000 "
                  "Y50.00000 F3000.000\n") != std::string::npos);
  CHECK(text.find("G0 ") == std::string::npos);
  CHECK(text.find("; song ends\nM400") != std::string::npos);
  const auto d = gcheck::decode(text);
  CHECK(d.homed);
  CHECK(write_gcode(plan_gcode(s, box(9, 9, 9), o), box(9, 9, 9), o, "a\nG28\r").find("; a?G28?\n") == 0);
  CHECK(d.start[0] == 50);
  CHECK(d.start[2] == 50);
  // Each axis's travel within its max feed: Z on an Ender-3 at 5 mm/s.
  const Printer &e = find_printer(builtin_printers(), "ender3");
  const std::string ender = write_gcode(plan_gcode(s, e, {}), e, {}, "song");
  CHECK(ender.find("G0 Z125.00000 F300.000 ; to the middle of the volume\nG0 X110.00000 Y110.00000 F3000.000\n") !=
        std::string::npos);
  o.steps_per_cycle = 0;
  CHECK(plan_error(s, box(100, 100, 100), o) == "steps per cycle must be above 0 and at most 64");
}

TEST_CASE("gcode: inputs the fuzzers found plan and end (a carriage rounding to a denormal room hung, a delta "
          "effector a micrometre outside)") {
  for (const char *name : {"border-denormal-hang.sng", "border-denormal-hang.mid", "delta-outside-by-tolerance.sng"}) {
    INFO(name);
    const Song s = read_song_file(std::string(STEPCHOIR_FUZZ_REGRESSIONS) + "/" + name);
    fuzz_plan(s);  // aborts on a coordinate outside the volume; ctest's timeout catches a hang
    const Printer p = make_printer("fuzz", "80,80,400,100", "0:10,-5:5,0:2", "200,200,5,25", "test");
    const GcodePlan plan = plan_gcode(s, p, {});
    CHECK(plan.steps.size() > 10);
  }
}

TEST_CASE("gcode: the checker finds broken G-code: a wrong feed, a coordinate outside, a moving rest, "
          "a missing last note, a wrong direction") {
  const Song s = song_of({{0, 0, 1, 69}, {1, 0.5, 1, 60}, {0, 1.5, 0.5, 72}});
  const Printer p = box(100, 100, 100);
  const GcodePlan plan = plan_gcode(s, p, {});
  const gcheck::Decoded good = gcheck::decode(write_gcode(plan, p, {}, "song"));
  REQUIRE(gcheck::problems(good, s, p, plan.axis_voice, 2).empty());
  auto with = [&](auto change) {
    gcheck::Decoded d = good;
    change(d);
    return gcheck::problems(d, s, p, plan.axis_voice, 2);
  };
  auto any = [](const std::vector<std::string> &found, const std::string &what) {
    for (const auto &f : found)
      if (f.find(what) != std::string::npos) return true;
    return false;
  };
  CHECK(any(with([](gcheck::Decoded &d) { d.moves[1].duration_s *= 1.01; }), "steps/s, the G-code makes"));
  CHECK(any(with([](gcheck::Decoded &d) { d.moves[0].to[1] = 100.5; }), "outside the volume"));
  CHECK(any(with([](gcheck::Decoded &d) { d.moves[0].to[1] += 1; }), "Y: silent, but moves"));
  CHECK(any(with([](gcheck::Decoded &d) {
              d.end_s -= d.moves.back().duration_s;
              d.moves.pop_back();
            }),
            "the G-code lasts"));
  // At 1.5 s X is at 61 mm (1 s of A4 up from 50): C5 must head down, toward 0.
  CHECK(any(with([](gcheck::Decoded &d) {
              for (auto &m : d.moves)
                if (std::fabs(m.start_s - 1.5) < 1e-6) m.to[0] = 2 * m.from[0] - m.to[0];
            }),
            "X: the note starts toward the border with less room"));
}

TEST_CASE("gcode: --extruder: E sings a fourth voice inside its 5 mm, timed alone when only it moves") {
  // Four voices; E alone from 2 s to 3 s (its feed is then measured on E).
  const Song s = song_of({{0, 0, 2, 60}, {1, 0, 2, 64}, {2, 0.5, 1, 55}, {3, 0, 3, 57}, {3, 3.5, 0.5, 62}});
  const Printer &e = find_printer(builtin_printers(), "ender3");
  GcodeOptions o;
  CHECK(plan_error(s, e, o).find("or add E with --extruder") != std::string::npos);
  o.extruder = true;
  const GcodePlan plan = plan_gcode(s, e, o);
  REQUIRE(plan.axis_voice.size() == 4);
  CHECK(plan.axis_count == 4);
  const std::string text = write_gcode(plan, e, o, "song");
  CHECK(text.find("M82 ; absolute extrusion\nG92 E0") != std::string::npos);
  CHECK(text.find("M302 P0") != std::string::npos);
  const gcheck::Decoded d = gcheck::decode(text);
  CHECK(d.start[kExtruderAxis] == 0);
  gcheck::check(d, s, e, plan.axis_voice, 2);
  // 3 s of A3 on 93 steps/mm is 10.5 mm of filament: E turned round inside +-5 mm.
  double lowest = 0, highest = 0;
  for (const auto &m : d.moves) lowest = std::min(lowest, m.to[kExtruderAxis]), highest = std::max(highest, m.to[kExtruderAxis]);
  CHECK(highest - lowest > 5);
  CHECK(highest <= kExtruderTravelMm);
  CHECK(lowest >= -kExtruderTravelMm);
  // Without E steps/mm there is no extruder to sing on.
  const Printer no_e = box(100, 100, 100);
  CHECK(plan_error(s, no_e, o) == "printer box has no E steps/mm; give them as --steps-per-mm X,Y,Z,E");
}

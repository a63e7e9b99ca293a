// test_gcode_cli.cpp: end to end, the real `stepchoir gcode` binary on song files: its G-code
// decoded back and checked against the score; bad input gives a clear error and exit code 1.
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "gcode_check.h"
#include "smf_builder.h"
#include "player/printer_arrangement.h"
#include "song/gcode.h"
#include "song/song.h"

using namespace stepchoir;

namespace {

// Runs `stepchoir gcode ARGS`, stderr to a file; returns the exit code and sets err. Called by
// the tests.
int run_gcode(const std::string &args, std::string &err) {
  // One file per test process: ctest may run this program's test cases side by side.
  const std::string err_file = std::string(STEPCHOIR_SCRATCH) + "/gcode_err." + std::to_string(getpid()) + ".txt";
  const int status = std::system((std::string(STEPCHOIR_BIN) + " gcode " + args + " 2>" + err_file).c_str());
  std::ifstream in(err_file);
  std::ostringstream text;
  text << in.rdbuf();
  err = text.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The whole text of a file. Called by the tests.
std::string slurp(const std::string &path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Writes bytes to a scratch file and returns its path. Called by the tests.
std::string scratch_file(const std::string &name, const std::string &bytes) {
  const std::string path = std::string(STEPCHOIR_SCRATCH) + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

}  // namespace

TEST_CASE("stepchoir gcode: the sample songs on the Cartesian, CoreXY and delta presets decode back to the score") {
  for (const char *file : {"9th.sng", "canon.sng", "furelise.sng"})
    for (const char *printer : {"ender3", "prusa-mk3s", "voron24", "prusa-core-one", "kossel"}) {
      INFO(file << " on " << printer);
      const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/" + file;
      const std::string out = std::string(STEPCHOIR_SCRATCH) + "/" + file + "." + printer + ".gcode";
      std::string err;
      REQUIRE(run_gcode(song + " -o " + out + " --printer " + printer + " --home --fold-octaves", err) == 0);
      INFO(err);
      CHECK(err.find(" moves, ") != std::string::npos);
      const Song s = read_song_file(song);
      const Printer &p = find_printer(builtin_printers(), printer);
      const gcheck::Decoded d = gcheck::decode(slurp(out));
      CHECK(d.homed);
      gcheck::check(d, s, p, plan_gcode(s, p, {}).axis_voice, kDefaultStepsPerCycle, true);
    }
}

TEST_CASE("stepchoir gcode: a MIDI file on an own printer, four voices arranged for three axes, two chosen, "
          "all four with --extruder") {
  smf::Track t;
  for (uint8_t ch = 0; ch < 4; ++ch) t.ev(0, {static_cast<uint8_t>(0x90 | ch), static_cast<uint8_t>(55 + 3 * ch), 100});
  for (uint8_t ch = 0; ch < 4; ++ch) t.ev(ch == 0 ? 960 : 0, {static_cast<uint8_t>(0x80 | ch), static_cast<uint8_t>(55 + 3 * ch), 0});
  t.end();
  const smf::Bytes bytes = smf::file(0, 480, {t});
  const std::string mid = scratch_file("four.mid", std::string(bytes.begin(), bytes.end()));
  const std::string out = std::string(STEPCHOIR_SCRATCH) + "/four.gcode";
  std::string err;
  // Four voices, three axes: the arranger keeps the melody (the top note, E4) and the bass (G3).
  REQUIRE(run_gcode(mid + " -o " + out + " --steps-per-mm 100,100,400 --volume 0:10,0:10,0:10", err) == 0);
  CHECK(err.find("warning: the song has 4 voices and the printer 3 axes: arranged, melody first, then bass; 3 of 4 "
                 "notes play (1 melody, 1 bass, 1 inner)") != std::string::npos);
  {
    const gcheck::Decoded d = gcheck::decode(slurp(out));
    std::vector<int> sung;
    for (size_t a = 0; a < kCartesianAxes; ++a) {
      double mm = 0, s_total = 0;
      for (const auto &m : d.moves) mm += std::fabs(m.to[a] - m.from[a]), s_total += m.duration_s;
      const double steps_s = mm * (a == 2 ? 400 : 100) / s_total;
      const double note = 69 + 12 * std::log2(steps_s / kDefaultStepsPerCycle / 440);
      CHECK(std::fabs(note - std::round(note)) < 0.01);
      sung.push_back(static_cast<int>(std::lround(note)));
    }
    std::sort(sung.begin(), sung.end());
    INFO("sung " << sung[0] << " " << sung[1] << " " << sung[2]);
    CHECK(sung.front() == 55);
    CHECK(sung.back() == 64);
    CHECK((sung[1] == 58 || sung[1] == 61));
    CHECK(d.end_s == Approx(1.0).margin(1e-3));
  }
  REQUIRE(run_gcode(mid + " -o " + out + " --steps-per-mm 100,100,400 --volume 0:10,0:10,0:10 --channels 3,0 "
                          "--max-feed 100,100,10",
                    err) == 0);
  const Song s = read_song_file(mid);
  const Printer p = make_printer("own", "100,100,400", "0:10,0:10,0:10", "100,100,10", "test");
  GcodeOptions o;
  o.voice_of_axis = {3, 0};
  gcheck::check(gcheck::decode(slurp(out)), s, p, plan_gcode(s, p, o).axis_voice, kDefaultStepsPerCycle);
  // All four voices with the extruder as the fourth axis.
  REQUIRE(run_gcode(mid + " -o " + out + " --printer prusa-mk3s --extruder", err) == 0);
  const Printer &mk3s = find_printer(builtin_printers(), "prusa-mk3s");
  GcodeOptions with_e;
  with_e.extruder = true;
  const gcheck::Decoded d = gcheck::decode(slurp(out));
  CHECK(d.cold_extrusion == false);  // allowed for the song, prevented again at its end
  gcheck::check(d, s, mk3s, plan_gcode(s, mk3s, with_e).axis_voice, kDefaultStepsPerCycle);
  CHECK(plan_gcode(s, mk3s, with_e).axis_voice.size() == 4);
}

TEST_CASE("stepchoir gcode: --kinematics corexy on an own printer: A and B sing the voices") {
  const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/9th.sng";
  const std::string out = std::string(STEPCHOIR_SCRATCH) + "/own-corexy.gcode";
  std::string err;
  REQUIRE(run_gcode(song + " -o " + out + " --steps-per-mm 80,80,400 --volume 0:60,0:40,0:20 --max-feed 300,300,5 "
                           "--kinematics corexy --fold-octaves",
                    err) == 0);
  INFO(err);
  CHECK(err.find("(corexy), A = track") != std::string::npos);
  Printer p = make_printer("custom", "80,80,400", "0:60,0:40,0:20", "300,300,5", "test");
  p.kinematics = Kinematics::kCoreXY;
  const Song s = read_song_file(song);
  GcodeOptions o;
  o.fold_octaves = true;
  gcheck::check(gcheck::decode(slurp(out)), s, p, plan_gcode(s, p, o).axis_voice, kDefaultStepsPerCycle, true);
  // The same G-code read as a Cartesian printer's plays the wrong rates: the check can fail.
  p.kinematics = Kinematics::kCartesian;
  CHECK_FALSE(gcheck::problems(gcheck::decode(slurp(out)), s, p, plan_gcode(s, p, o).axis_voice,
                               kDefaultStepsPerCycle, true).empty());
  CHECK(run_gcode(song + " -o " + out + " --printer ender3 --kinematics delta", err) != 0);
}

TEST_CASE("stepchoir gcode: a tab and a MusicXML score become G-code as play reads them") {
  for (const char *file : {"riff.tab", "duet.mxl"}) {
    INFO(file);
    const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/" + file;
    const std::string out = std::string(STEPCHOIR_SCRATCH) + "/" + file + ".gcode";
    std::string err;
    REQUIRE(run_gcode(song + " -o " + out + " --printer prusa-mk3s --fold-octaves", err) == 0);
    INFO(err);
    const Song read = read_song_file(song);
    REQUIRE(read.notes.size() > 10);
    const Printer &p = find_printer(builtin_printers(), "prusa-mk3s");
    // the tab's six strings are six voices: arranged for the three axes, as the command says
    std::vector<std::string> said;
    const Song s = voices_of(read).size() > 3 ? arrange_for_printer(read, p, 3, kDefaultStepsPerCycle, said) : read;
    CHECK((said.empty() || err.find(said[0]) != std::string::npos));
    GcodeOptions o;
    o.fold_octaves = true;
    gcheck::check(gcheck::decode(slurp(out)), s, p, plan_gcode(s, p, o).axis_voice, kDefaultStepsPerCycle, true);
  }
}

TEST_CASE("stepchoir gcode: --printer-file reads presets from a file, and names the line of a bad one") {
  const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/furelise.sng";
  const std::string out = std::string(STEPCHOIR_SCRATCH) + "/own-presets.gcode";
  const std::string good = scratch_file("presets.conf", "# mine\nsmall 160,160,800 0:30,0:40,0:20 300,300,8 a small one\n");
  std::string err;
  REQUIRE(run_gcode(song + " -o " + out + " --printer-file " + good + " --printer small", err) == 0);
  const Printer p = parse_printers(slurp(good), "presets.conf")[0];
  const Song s = read_song_file(song);
  gcheck::check(gcheck::decode(slurp(out)), s, p, plan_gcode(s, p, {}).axis_voice, kDefaultStepsPerCycle);
  const std::string bad = scratch_file("bad-presets.conf", "small 160,160,800 0:30,0:40,0:20 300,300,8 ok\nbig 1,2 x y\n");
  CHECK(run_gcode(song + " -o " + out + " --printer-file " + bad + " --printer small", err) == 1);
  CHECK(err.find("stepchoir gcode: " + bad + ":2: expected steps/mm as X,Y,Z or X,Y,Z,E, got '1,2'") == 0);
}

TEST_CASE("stepchoir gcode: bad songs and options exit 1 with what and where") {
  const std::string out = std::string(STEPCHOIR_SCRATCH) + "/bad.gcode";
  const std::string bad = scratch_file("bad.sng", "TEMPO 120\nBEGINCH\nA 4 1\nc 4 1\nENDCH\n");
  const std::string trunc = scratch_file("trunc.mid", std::string("MThd\0\0\0\6\0\0\0\1\0\x60MTrk\0\0\0\x40\0", 23));
  const std::pair<std::string, std::string> cases[] = {
      {bad + " -o " + out, "stepchoir gcode: " + bad + ":4: note name 'c'"},
      {trunc + " -o " + out, "stepchoir gcode: " + trunc + ": byte 22 (chunk 1 'MTrk' at byte 14, track 0): chunk length 64 runs past"},
      {"/nonexistent.sng -o " + out, "stepchoir gcode: /nonexistent.sng: cannot open: No such file"},
      {std::string(STEPCHOIR_SCRATCH) + " -o " + out, "stepchoir gcode: " + std::string(STEPCHOIR_SCRATCH) + ": cannot read: Is a directory"},
      {bad + " -o " + out + " --printer mk4", "stepchoir gcode: " + bad + ":4"},
  };
  for (const auto &[args, error] : cases) {
    std::string err;
    CHECK(run_gcode(args, err) == 1);
    CHECK(err.find(error) == 0);
  }
  const std::string good = std::string(STEPCHOIR_SONGS_DIR) + "/9th.sng";
  const std::pair<std::string, std::string> options[] = {
      {" --printer mk4", "no printer named 'mk4'; known: ender3, prusa-mk3s, voron24, prusa-core-one, kossel, generic"},
      {" --printer ender3 --volume 0:1,0:1,0:1", "give either --printer or --steps-per-mm and --volume, not both"},
      {" --steps-per-mm 80,80,400", "--steps-per-mm and --volume go together"},
      {" --steps-per-mm 80,80 --volume 0:9,0:9,0:9", "options: expected steps/mm as X,Y,Z"},
      {" --channels 0,x", "--channels: expected voice numbers such as 0,2,1, got 'x'"},
      {" --max-feed 1,2", "--max-feed: expected max feed (mm/s) as X,Y,Z"},
  };
  for (const auto &[args, error] : options) {
    std::string err;
    CHECK(run_gcode(good + " -o " + out + args, err) == 1);
    CHECK(err.find("stepchoir gcode: " + error) != std::string::npos);
  }
}

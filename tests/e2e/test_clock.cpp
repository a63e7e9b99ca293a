// test_clock.cpp: `stepchoir play` (and `jam`) on a virtual board whose crystal is off, end to
// end: the host's clock fit measures the board's rate through the link (ideal, or a USB
// bridge's model) and keeps refining it while the song plays, and every note is checked in real time in the
// trace (the trace's cycles divided by the simulated crystal's real rate). A board met before
// (its id in its EEPROM, its crystal in the host's memory) is in tune from its first note.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <sys/stat.h>

#include "e2e_util.h"
#include "jack_rig.h"
#include "play_checks.h"
#include "smf_builder.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
using e2e::scratch;

namespace {

// A format 1 file of `seconds` at 120 bpm: a legato melody in eighths (track 1, channel 1)
// over a bass in half notes (track 2, channel 2).
std::string write_long_song(const std::string &name, int seconds) {
  const uint16_t ppq = 480;
  smf::Track tempo;
  tempo.tempo(0, 500000).end(0);
  smf::Track melody;
  const int tune[] = {72, 74, 76, 77, 79, 77, 76, 74, 72, 71, 69, 71};
  const int eighths = seconds * 4;
  for (int i = 0; i < eighths; ++i) {
    const uint8_t key = static_cast<uint8_t>(tune[i % 12]);
    melody.ev(0, {0x90, key, 90}).ev(ppq / 2, {0x80, key, 0});
  }
  melody.end(0);
  smf::Track bass;
  const int line[] = {48, 43, 45, 41};
  for (int i = 0; i < seconds; ++i) {
    const uint8_t key = static_cast<uint8_t>(line[i % 4]);
    bass.ev(0, {0x91, key, 80}).ev(2 * ppq - 60, {0x81, key, 0}).ev(60, {0xB1, 7, 100});
  }
  bass.end(0);
  const auto bytes = smf::file(1, ppq, {tempo, melody, bass});
  const std::string path = scratch(name);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char *>(bytes.data()),
                                               static_cast<std::streamsize>(bytes.size()));
  return path;
}

// What a run must meet: from 2 s into the song, every note within early_cents in real time
// and the tempo within early_tempo_ppm (and, with early_onsets, onsets within 0.5 ms of the
// line, 99 %); from 10 s on, every note within late_cents and onsets within 0.5 ms of that
// part's line.
struct Bounds {
  double early_cents, early_tempo_ppm, late_cents;
  bool early_onsets;
};

// How far a note's end may move from its planned end (us): a step in the timeline as the clock
// fit refines would open a gap in the legato line, or run one note into the next.
constexpr double kLegatoUs = 250.0;

// A 12 s song on a board met for the first time, its crystal ppm off, over `link`, checked in
// real time from the trace against `b`. (Not check_song's 0.5 cent from the first note: the
// rate is still being measured then.)
// jam: the song through `stepchoir jam` on motors 0 and 1, a JACK keyboard (silent) on the
// others.
void check_refined(const std::string &link, const std::string &ppm, const Bounds &b, bool jam = false) {
  const std::string name = std::string(jam ? "clock-jam-" : "clock-") + link + ppm;
  const std::string song = write_long_song(name + ".mid", 12);
  const std::string trace_path = scratch(name + ".csv");
  std::vector<std::string> args = {jam ? "jam" : "play", song, "--tracks", "1,2", "--vboard", "uno", "--vboard-link",
                                   link, "--clock-ppm", ppm, "--vboard-trace", trace_path, "--quiet"};
  std::unique_ptr<JackServer> jack;
  std::unique_ptr<Sender> keys;
  if (jam) {
    jack = std::make_unique<JackServer>(1024);
    keys = std::make_unique<Sender>();
    args.insert(args.end(), {"--midi-api", "jack", "--midi", Sender::kPort, "--song-motors", "0,1"});
  }
  int status = -1;
  const std::string out = run_stepchoir(args, &status);
  INFO(out);
  REQUIRE(status == 0);
  const auto t = sc::trace::read_trace(trace_path);
  require_real_time(t);
  REQUIRE(t.clock_ppm == Approx(std::stod(ppm)));
  bool on_link = false;  // the board's summary names the link model it ran
  for (const std::string &line : t.summary_lines) on_link |= line.find(" link_model=" + link + " ") != std::string::npos;
  REQUIRE(on_link);
  const Plan plan = plan_for(song, jam ? 2 : static_cast<size_t>(t.motors), 1.0, {1, 2});
  REQUIRE(plan.notes.size() == 48 + 12);
  const std::string what = std::string(jam ? "clock, jam, " : "clock, ") + link + " link, crystal " + ppm + " ppm";
  const sc::trace::ScoreCheck early = check_played(t, plan, 2.0);
  print_figures((what + ", from 2 s").c_str(), early);
  const sc::trace::ScoreCheck late = check_played(t, plan, 10.0);
  print_figures((what + ", from 10 s").c_str(), late);
  INFO(late.first_problem);
  CHECK(late.found == late.notes);
  CHECK(pct(late.onset_err_us, 0.99) < 500.0);
  CHECK(late.max_cents < b.late_cents);
  CHECK(late.max_release_early_us < kLegatoUs);
  CHECK(late.max_release_late_us < kLegatoUs);
  INFO(early.first_problem);
  CHECK(early.found == early.notes);
  CHECK(early.max_cents < b.early_cents);
  CHECK(early.max_release_early_us < kLegatoUs);
  CHECK(early.max_release_late_us < kLegatoUs);
  CHECK(std::fabs(early.tempo_ppm) < b.early_tempo_ppm);
  if (b.early_onsets) CHECK(pct(early.onset_err_us, 0.99) < 500.0);
}

}  // namespace

// The targets (issue 23): 0.5 cent and 100 ppm from 2 s, 0.1 cent from 10 s.
TEST_CASE("clock: a crystal 0.5 % slow on the ideal link - in tune from 2 s, within 0.1 cent after 10 s (auto-tune)",
          "[play][clock][pacing]") {
  check_refined("ideal", "-5000", {0.5, 100.0, 0.1, true});
}

// Behind a USB bridge model the same targets: a board met for the first time syncs until its
// rate is within 30 ppm (up to 3 s) before the first note.
TEST_CASE("clock: a crystal 0.5 % fast behind a 16U2 bridge - in tune from 2 s, within 0.1 cent after 10 s (auto-tune)",
          "[play][clock][pacing]") {
  check_refined("16u2", "5000", {0.5, 100.0, 0.1, true});
}

TEST_CASE("clock: a crystal 0.5 % slow behind an FTDI bridge - in tune from 2 s, within 0.1 cent after 10 s (auto-tune)",
          "[play][clock][pacing]") {
  check_refined("ftdi", "-5000", {0.5, 100.0, 0.1, true});
}

// jam: the song shares the board with the live path, its clock requests sent by the live
// writer, and keeps refining the board's rate as play does.
TEST_CASE("clock: jam with a crystal 0.5 % fast behind a 16U2 bridge - the song in tune from 2 s, within 0.1 cent "
          "after 10 s",
          "[play][jam][clock][pacing]") {
  check_refined("16u2", "5000", {0.5, 100.0, 0.1, true}, true);
}

TEST_CASE("play: without auto-tune the same crystal plays 8.6 cents off (the check can fail)", "[play][pacing]") {
  const std::string song = write_test_song("play-notune.mid");
  const std::string trace_path = scratch("play-notune.csv");
  int status = -1;
  const std::string out = run_stepchoir(
      {"play", song, "--tracks", "1,2", "--vboard", "uno", "--clock-ppm", "5000", "--no-auto-tune", "--vboard-trace",
       trace_path, "--quiet"},
      &status);
  REQUIRE(status == 0);
  const auto t = sc::trace::read_trace(trace_path);
  require_real_time(t);
  const sc::trace::ScoreCheck c = check_played(t, plan_for(song, static_cast<size_t>(t.motors), 1.0, {1, 2}));
  CHECK(c.max_cents == Approx(1200 * std::log2(1.005)).margin(1.0));
  CHECK(c.max_spread_cents < 0.05);
}

namespace {

// The same board (one EEPROM file) plays a 4 s song, then the 12 s one, on `link` with its
// crystal ppm off, through `stepchoir play --port`, the host's memory in a scratch directory.
// The second time it is a board met before: checked in real time from the trace, from the
// first note on, against the targets (issue 23): 0.5 cent, tempo 100 ppm, onsets p99 0.5 ms.
void check_remembered(const std::string &link, const std::string &ppm) {
  const std::string name = "memory-" + link + ppm;
  const std::string first_song = write_long_song(name + "-first.mid", 4), song = write_long_song(name + ".mid", 12);
  const std::string eeprom = scratch(name + ".eeprom"), cache = scratch(name + "-cache");
  std::remove(eeprom.c_str());
  std::remove((cache + "/stepchoir/boards.toml").c_str());
  ::setenv("XDG_CACHE_HOME", cache.c_str(), 1);  // the children read it
  struct Restore {
    ~Restore() { ::unsetenv("XDG_CACHE_HOME"); }
  } restore;
  std::string id;
  for (int run = 0; run < 2; ++run) {
    const std::string trace_path = scratch(name + "-" + std::to_string(run) + ".csv");
    VboardProcess vb({"--board", "uno", "--eeprom", eeprom, "--link-model", link, "--clock-ppm", ppm, "--trace",
                      trace_path, "--quiet", "--no-measure"});
    int status = -1;
    const std::string out =
        run_stepchoir({"play", run == 0 ? first_song : song, "--tracks", "1,2", "--port", vb.pty(), "--quiet"}, &status);
    INFO(out);
    REQUIRE(status == 0);
    REQUIRE(vb.stop() == 0);
    const size_t at = out.find(" is board ");
    REQUIRE(at != std::string::npos);
    if (run == 0) {
      CHECK(out.find("met for the first time") != std::string::npos);
      id = out.substr(at + 10, 16);
      continue;
    }
    CHECK(out.substr(at + 10, 16) == id);  // the id stayed in the board's EEPROM
    CHECK(out.find("met before: crystal ") != std::string::npos);
    const auto t = sc::trace::read_trace(trace_path);
    require_real_time(t);
    const Plan plan = plan_for(song, static_cast<size_t>(t.motors), 1.0, {1, 2});
    const sc::trace::ScoreCheck c = check_played(t, plan, 0.0);
    print_figures(("clock, " + link + " link, crystal " + ppm + " ppm, a board met before").c_str(), c);
    INFO(c.first_problem);
    CHECK(c.found == c.notes);
    CHECK(c.max_cents < 0.5);
    CHECK(std::fabs(c.tempo_ppm) < 100.0);
    CHECK(pct(c.onset_err_us, 0.99) < 500.0);
    // The legato line keeps its joins: no step in the timeline as the fit refines.
    CHECK(c.max_release_early_us < kLegatoUs);
    CHECK(c.max_release_late_us < kLegatoUs);
    const sc::trace::ScoreCheck late = check_played(t, plan, 10.0);
    print_figures(("clock, " + link + " link, crystal " + ppm + " ppm, a board met before, from 10 s").c_str(), late);
    CHECK(late.found == late.notes);
    CHECK(late.max_cents < 0.1);
  }
}

}  // namespace

// The crystals' signs opposite to the first-time cases': each link meets both.
TEST_CASE("clock: a board met before, crystal 0.5 % slow behind a 16U2 bridge - in tune from the first note",
          "[play][clock][pacing]") {
  check_remembered("16u2", "-5000");
}

TEST_CASE("clock: a board met before, crystal 0.5 % fast behind an FTDI bridge - in tune from the first note",
          "[play][clock][pacing]") {
  check_remembered("ftdi", "5000");
}

// The CH340 model, for bench/results/clock-links.md only (hidden: run by name or by [.bench]).
TEST_CASE("clock: a crystal 0.5 % fast behind a CH340 bridge - in tune from 2 s, within 0.1 cent after 10 s",
          "[.bench][play][clock][pacing]") {
  check_refined("ch340", "5000", {0.5, 100.0, 0.1, true});
}

TEST_CASE("clock: a board met before, crystal 0.5 % slow behind a CH340 bridge - in tune from the first note",
          "[.bench][play][clock][pacing]") {
  check_remembered("ch340", "-5000");
}

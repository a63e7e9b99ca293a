// test_arrange.cpp: the arranger end to end: a General MIDI band arrangement (melody, bass,
// chords, a counter-line and drums) through `stepchoir render` on the virtual board, as
// `stepchoir play` plans it for the board's four motors: every planned note is in the trace,
// on time and in tune, and no drum hit is sung; with --drums, the hits sound as bursts on their
// own motor. A MusicXML score (repeats, a transposing part) renders the same way.
#include <catch2/catch.hpp>

#include <cstdio>
#include <string>
#include <vector>

#include "e2e_util.h"
#include "play_checks.h"
#include "trace.h"

using namespace stepchoir;
using namespace play_checks;
using e2e::scratch;

TEST_CASE("render: a General MIDI band song arranged for four motors, drums left out or as bursts",
          "[play][pacing]") {
  // The blues at twice its tempo (dense: the board's queue stays full), as arranged and with
  // --drums 3.
  for (const bool drums : {false, true}) {
    INFO((drums ? "band-blues.mid --drums 3" : "band-blues.mid"));
    const std::string path = std::string(STEPCHOIR_SONGS_DIR) + "/band-blues.mid";
    const Song song = read_song_file(path);
    size_t percussion = 0;
    for (const SongNote &n : song.notes) percussion += n.percussion;
    REQUIRE(percussion > 50);
    const std::string trace_path = scratch(drums ? "arrange-drums.csv" : "arrange.csv");
    std::vector<std::string> args{"render", path, "--tempo", "2", "-o", scratch("arrange.wav"), "--trace", trace_path};
    if (drums) args.insert(args.end(), {"--drums", "3"});
    int status = -1;
    const std::string out = run_stepchoir(args, &status);
    INFO(out);
    REQUIRE(status == 0);
    // the host kept within the board's queue, however the simulation's speed varied
    CHECK(out.find("queue full 0,") != std::string::npos);
    CHECK(out.find("0 bad frames") != std::string::npos);
    const auto t = sc::trace::read_trace(trace_path);
    REQUIRE(t.motors == 4);
    PlanOptions o;
    o.tempo_scale = 2;
    o.motors.assign(4, MotorConfig{});
    if (drums) o.drum_motor = 3;
    const Plan plan = plan_song(song, o);
    size_t bursts = 0, left_out = 0;
    for (const PlannedNote &n : plan.notes) {
      if (!song.notes[n.song_index].percussion) continue;
      CHECK(n.role == Role::kPercussion);  // never sung as a pitch
      CHECK(n.motor == 3);
      ++bursts;
    }
    for (const UnplayedNote &u : plan.unplayed) left_out += u.why == Unplayed::kPercussion;
    if (drums) {
      CHECK(bursts > percussion / 2);  // hits at one time sound as the one that matters most
    } else {
      CHECK(bursts == 0);
      CHECK(left_out == percussion);
    }
    const sc::trace::ScoreCheck c = check_song(drums ? "render, drums" : "render, arranged", t, plan);
    // Board time: the nominal clock exactly. A kick's burst has three or four edges, so its
    // pitch is fitted from few.
    CHECK(c.max_cents < (drums ? 0.1 : 0.05));
  }
}

TEST_CASE("render: a MusicXML score (.mxl) through the firmware, every planned note played", "[play][pacing]") {
  const std::string path = std::string(STEPCHOIR_SONGS_DIR) + "/duet.mxl";
  const std::string trace_path = scratch("duet.csv");
  int status = -1;
  const std::string out =
      run_stepchoir({"render", path, "--tempo", "2", "-o", scratch("duet.wav"), "--trace", trace_path}, &status);
  INFO(out);
  REQUIRE(status == 0);
  const auto t = sc::trace::read_trace(trace_path);
  PlanOptions o;
  o.tempo_scale = 2;
  o.motors.assign(static_cast<size_t>(t.motors), MotorConfig{});
  const Song song = read_song_file(path);
  const Plan plan = plan_song(song, o);
  CHECK(plan.notes.size() == song.notes.size());  // two parts, at most four notes at once
  const sc::trace::ScoreCheck c = check_song("render, MusicXML", t, plan);
  CHECK(c.max_cents < 0.05);
}

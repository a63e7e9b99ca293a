// test_setlist.cpp: live's setlist end to end, a JACK keyboard and `stepchoir live` on the real
// firmware on an Uno virtual board. Item 1 plays a song jam style on motors 0 and 1 (its preset
// mutes them for the keyboard) while keys play on motors 2 and 3; a learned pedal (CC 20) steps
// to item 2, a plain preset; again to item 3, the song on motors 2 and 3, and CC 21 steps back
// from it mid-song. Read from the trace: the song on time and in tune, the keys on the other
// motors, and nothing of the stopped song after the step back. The board resets (its button)
// before the encore, which finds it set up again from the rig file, and again in the encore's
// middle, which plays on. The songs measure the board's crystal, and the host remembers it.
#include <catch2/catch.hpp>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "known_board.h"
#include "play_checks.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;
using namespace play_checks;

namespace {

void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

}  // namespace

TEST_CASE("live: a setlist plays a song jam style, steps on a pedal, and stops a song stepped away from",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string song = write_test_song("setlist.mid");
  const std::string trace_path = e2e::scratch("setlist.csv"), config_path = e2e::scratch("setlist.toml");
  // A board the host remembers with an exact crystal, whose crystal is 300 ppm fast: each song
  // measures it, and the host remembers what the song measured.
  const uint64_t id = 0x0807060504030231;
  const e2e::KnownBoard known("setlist", id, 0.0);
  VboardProcess vb({"--board", "uno", "--eeprom", known.eeprom, "--clock-ppm", "300", "--trace", trace_path, "--quiet",
                    "--no-measure"});
  std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n\n"
                             << "[[presets]]\nprogram = 1\nname = \"plain\"\n\n"
                             << "[[presets]]\nprogram = 2\nname = \"duet\"\nmute_motors = [0, 1]\n\n"
                             << "[[controls]]\naction = \"setlist_next\"\ncc = 20\n\n"
                             << "[[controls]]\naction = \"setlist_previous\"\ncc = 21\n\n"
                             << "[setlist]\nitems = [\n  { song = \"" << song << "\", preset = \"duet\" },\n"
                             << "  { preset = \"plain\" },\n  { song = \"" << song << "\", song_motors = [2, 3], name = \"encore\" },\n]\n\n"
                             << "[[boards]]\nport = \"" << vb.pty() << "\"\n"
                             << "[[boards.motors]]\n[[boards.motors]]\n[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 5\n";
  auto press = [&](uint8_t cc) {
    const double at = keys.send(stepchoir::control_change(0, cc, 127));
    wait_ms(50);
    keys.send(stepchoir::control_change(0, cc, 0));
    return at;
  };
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
  std::string said;
  const std::string first = wait_for_line(live, "live: setlist 1/3", &said);
  INFO("stepchoir live said:\n" << said);
  REQUIRE(first == "live: setlist 1/3 duet: the song on motors 0,1");
  wait_ms(300);  // JACK takes the new connection
  using Key = Sender::Key;
  const std::vector<Key> during = {{1.7, 2.3, 62}, {2.0, 2.6, 65}};  // while the song plays
  keys.play(during);
  REQUIRE(wait_for_line(live, "live: setlist 1/3 duet: the song ended", &said) != "");
  press(20);
  REQUIRE(wait_for_line(live, "live: setlist 2/3", &said) == "live: setlist 2/3 plain");
  wait_ms(200);
  keys.play({{0.0, 0.4, 60}});  // plain: motor 0
  wait_ms(200);
  // Between the songs the board resets with its link up (its button): live sets it up again
  // from the rig file before the encore.
  REQUIRE(::kill(vb.pid(), SIGUSR1) == 0);
  REQUIRE(wait_for_line(live, "live: " + vb.pty() + ": the board restarted; setting it up again", &said) != "");
  REQUIRE(wait_for_line(live, "live: " + vb.pty() + ": set up again", &said) != "");
  press(20);
  REQUIRE(wait_for_line(live, "live: setlist 3/3", &said) == "live: setlist 3/3 encore: the song on motors 2,3");
  const double encore_s = Sender::now_s();
  wait_ms(2000);  // its clock synced, a few notes in
  // The button again, in the middle of the encore: live sets the board up again, and the
  // encore's player syncs again and plays on.
  REQUIRE(::kill(vb.pid(), SIGUSR1) == 0);
  REQUIRE(wait_for_line(live, "live: " + vb.pty() + ": the board restarted; setting it up again", &said) != "");
  REQUIRE(wait_for_line(live, "live: " + vb.pty() + ": set up again", &said) != "");
  wait_ms(1500);  // synced again, a few notes more; the song is still playing at the step back
  const double back_s = press(21);
  REQUIRE(wait_for_line(live, "live: setlist 2/3", &said) == "live: setlist 2/3 plain");
  wait_ms(500);
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  const std::vector<e2e::Sounded> sounded = e2e::sounded_notes_logged(t);
  // The song: its plan on motors 0 and 1, as `stepchoir play` makes it for two motors.
  const Plan plan = plan_for(song, 2);
  check_song("setlist, the song on motors 0 and 1", t, plan, 0, PitchCheck::kOneRate);
  // The keys during the song, on motors 2 and 3; the key after it, on motor 0.
  for (const Key &k : during) {
    INFO("key " << int{k.note});
    const e2e::Sounded *on2 = e2e::find_sounded(sounded, 2, k.note), *on3 = e2e::find_sounded(sounded, 3, k.note);
    REQUIRE((on2 || on3));
    const e2e::Sounded &s = on2 ? *on2 : *on3;
    CHECK(std::fabs(s.pitch - k.note) * 100 < 1.0);
    CHECK((s.end_s - s.start_s) == Approx(k.off_s - k.on_s).margin(0.03));
  }
  const e2e::Sounded *plain = e2e::find_sounded(sounded, 0, 60);
  REQUIRE(plain);
  CHECK(std::fabs(plain->pitch - 60) * 100 < 1.0);
  // The encore sounded on motors 2 and 3 and stopped at the step back: no step after it but the
  // JACK period (21 ms) and live's loop noticing the step (every 100 ms); the song's entries
  // already queued on the board are dropped (silence), not played out.
  REQUIRE(t.has_wall_start);
  size_t encore_steps = 0;
  double last_s = 0;
  for (size_t m : {2, 3})
    for (const auto &st : t.motor[m].steps) {
      const double wall = t.wall_seconds(t.real_seconds(st.rise_cycle));
      if (wall > encore_s) ++encore_steps;
      last_s = std::max(last_s, wall);
    }
  std::printf("setlist: the encore's last step %.1f ms after the step back\n", (last_s - back_s) * 1e3);
  CHECK(encore_steps > 0);
  CHECK(last_s - back_s < 0.25);  // entries played out would run on for the lead, 0.3 s
  // The encore after each reset: motor 2 with the rig file's TB6600 pulses again (motor 3 keeps
  // the default), and the encore sounding on after the one in its middle.
  REQUIRE(t.mcu_resets.size() == 2);  // the button, twice (this board is not reset by an open)
  check_tb6600_pulses(t, 2, 3, t.mcu_resets[0]);
  check_tb6600_pulses(t, 2, 3, t.mcu_resets[1]);
  const double second_reset_s = t.wall_seconds(t.real_seconds(t.mcu_resets[1]));
  std::vector<double> after;  // the encore's steps after the button in its middle, wall seconds
  for (size_t m : {2, 3})
    for (const auto &st : t.motor[m].steps) {
      const double wall = t.wall_seconds(t.real_seconds(st.rise_cycle));
      if (wall > second_reset_s && wall < back_s) after.push_back(wall);
    }
  std::sort(after.begin(), after.end());
  REQUIRE(!after.empty());
  const double again_s = after.front() - second_reset_s;
  double gap_s = 0;  // the melody plays throughout: once back, the encore keeps sounding
  for (size_t i = 1; i < after.size(); ++i) gap_s = std::max(gap_s, after[i] - after[i - 1]);
  std::printf("setlist: the encore sounded again %.2f s after the button in its middle (%zu steps, longest gap %.0f ms)\n",
              again_s, after.size(), gap_s * 1e3);
  CHECK(after.size() > 100);
  CHECK(gap_s < 0.5);
  CHECK(again_s < 2.5);  // live's set-up, then the player's sync again (a second)
  // The songs' measure of the crystal, remembered for the next evening: within three of its
  // own standard deviations of the true 300 ppm. A setlist song measures the rate from its
  // first second of round trips, to about 10 ppm.
  const std::optional<stepchoir::BoardRecord> record =
      stepchoir::recall_board(id, e2e::scratch("setlist-cache") + "/stepchoir/boards.toml");
  REQUIRE(record);
  INFO("remembered: crystal " << record->clock_ppm << " ppm (+/- " << record->sigma_ppm << ")");
  CHECK(record->sigma_ppm < 15);
  CHECK(std::fabs(record->clock_ppm - 300) < 3 * record->sigma_ppm);
}

// test_motion.cpp: moves on the real firmware, end to end: `stepchoir home` brings carriages
// that start at either end or off centre to the middle of the rail on both boards, a switch
// that never fires stops the motor with a clear error, and `jog` follows the seed's Torricelli
// ramp, checked step by step from the trace in board cycles. With home_on_start, play and jam
// home the switched carriages before the song.
//
// The boards run paced, the homing ones at twice real time: the host heartbeats every 50 ms
// (and its loop's time) while a motor moves, 100 ms of board time, within the watchdog's
// 300 ms; a machine that stalls the host past it stops the move (hence [pacing]).
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "jack_rig.h"
#include "play_checks.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
namespace tr = sc::trace;

namespace {

const int64_t kTravel = 3200;  // the virtual board's rail and the configuration's travel_steps

// A rig file for the board at `port`: top-level keys `top`, four motors with the motion keys
// `keys`.
std::string motion_config(const std::string &name, const std::string &port, const std::string &keys,
                          const std::string &top = "") {
  const std::string file = scratch(name + ".toml");
  std::ofstream f(file);
  f << top << "[[boards]]\nport = \"" << port << "\"\n";
  for (int m = 0; m < 4; ++m) f << "[[boards.motors]]\ntravel_steps = " << kTravel << "\n" << keys;
  return file;
}

// The carriage's position after motor m's last step (its start when it never stepped).
int64_t final_position(const tr::Trace &t, size_t m, int64_t start) {
  const auto &s = t.motor.at(m).steps;
  return s.empty() ? start : s.back().position;
}

}  // namespace

TEST_CASE("home: carriages at either end or off centre end in the middle, the rail measured", "[play][pacing]") {
  struct Case {
    const char *board;
    int64_t start;
    std::vector<std::string> motors;  // --motor options
    std::vector<size_t> homed;
  };
  const Case cases[] = {
      {"mega", 0, {"--motor", "0"}, {0}},                     // min and max switches: at the min end
      {"mega", kTravel, {"--motor", "1"}, {1}},               // at the max end
      {"mega", 700, {}, {0, 1, 2}},                           // off centre: every motor with switches
      {"uno", kTravel - 100, {"--motor", "2"}, {2}},          // one input for both ends
  };
  for (const Case &c : cases) {
    INFO(c.board << " from " << c.start);
    const std::string trace_path = scratch("home.csv");
    VboardProcess vb({"--board", c.board, "--speed", "2", "--trace", trace_path, "--quiet", "--no-measure", "--start-position",
                      std::to_string(c.start)});
    const std::string config = motion_config("home", vb.pty(), "home_speed = 30.0\n");
    std::vector<std::string> args{"home", "--port", vb.pty(), "--config", config};
    args.insert(args.end(), c.motors.begin(), c.motors.end());
    int status = -1;
    const std::string out = run_stepchoir(args, &status);
    INFO(out);
    REQUIRE(status == 0);
    REQUIRE(vb.stop() == 0);
    const tr::Trace t = tr::read_trace(trace_path);
    for (size_t m = 0; m < static_cast<size_t>(t.motors); ++m) {
      INFO("motor " << m);
      const bool homed = std::find(c.homed.begin(), c.homed.end(), m) != c.homed.end();
      if (!homed) {
        CHECK(t.motor[m].steps.empty());  // the others stay where they are
        continue;
      }
      CHECK(final_position(t, m, c.start) == kTravel / 2);
      // It touched the first switch twice and the other one once: six presses and releases, or
      // five when it started on the first switch (pressed from power-up, no change recorded).
      CHECK(t.motor[m].endstop_changes.size() >= 5u);
      CHECK(out.find("motor " + std::to_string(m) + ": in the middle, position 1600") != std::string::npos);
      CHECK(out.find("travel 3200 steps") != std::string::npos);
      int64_t lo = c.start, hi = c.start;
      for (const tr::Step &s : t.motor[m].steps) lo = std::min(lo, s.position), hi = std::max(hi, s.position);
      CHECK(lo == 0);  // it stopped on the step that reached each switch: no run past the rail
      CHECK(hi == kTravel);
    }
  }
}

TEST_CASE("home: a switch that never fires is reported, the motor stops within its search, and the others end in "
          "the middle",
          "[play][pacing]") {
  const std::string trace_path = scratch("home-dead.csv");
  VboardProcess vb({"--board", "mega", "--speed", "2", "--trace", trace_path, "--quiet", "--no-measure", "--dead-switch", "0"});
  const std::string config = motion_config("home-dead", vb.pty(), "home_speed = 40.0\n");
  int status = -1;
  const std::string out = run_stepchoir_all({"home", "--port", vb.pty(), "--config", config}, &status);
  INFO(out);
  CHECK(status == 1);
  CHECK(out.find("motor 0: the min switch did not fire within 4000 steps (50.0 mm): the motor stopped") !=
        std::string::npos);
  CHECK(out.find("motor 0: in the middle") == std::string::npos);
  for (const char *m : {"motor 1", "motor 2"})
    CHECK(out.find(std::string(m) + ": in the middle, position 1600") != std::string::npos);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // nothing more moves after the exit
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  const auto &s = t.motor[0].steps;
  REQUIRE_FALSE(s.empty());
  const int64_t search = kTravel + kTravel / 4;
  CHECK(int64_t(s.size()) == search);  // down the whole search, not a step more
  CHECK(s.back().position == kTravel / 2 - search);
  CHECK(t.motor[0].endstop_changes.empty());
  for (size_t m : {1u, 2u}) CHECK(final_position(t, m, kTravel / 2) == kTravel / 2);
}

TEST_CASE("jog: the move follows the Torricelli ramp, v^2 = v0^2 + 2as, up, at speed, and down", "[play][pacing]") {
  const std::string trace_path = scratch("jog.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // 80 steps/mm: v0 400 steps/s, vmax 3,200 steps/s, a = 16,000 steps/s^2.
  const std::string config = motion_config("jog", vb.pty(),
                                           "steps_per_mm = 80.0\nmin_speed = 5.0\nmax_speed = 40.0\nacceleration = 200.0\n");
  const int64_t steps = 1500;
  int status = -1;
  const std::string out = run_stepchoir(
      {"jog", "--port", vb.pty(), "--config", config, "--motor", "3", "--steps", std::to_string(-steps)}, &status);
  INFO(out);
  REQUIRE(status == 0);
  CHECK(out.find("moved 1500 steps") != std::string::npos);
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  const auto &s = t.motor[3].steps;
  REQUIRE(int64_t(s.size()) == steps);
  CHECK(s.back().position == kTravel / 2 - steps);
  const double v0 = 400, vmax = 3200, a = 16000;
  // Each interval's speed against the ramp's (rounded down to whole steps/s, as the firmware
  // does); an edge a few cycles late (an ISR ahead of it) shortens the next interval as much.
  double worst = 0, sum_err = 0, took = 0, ideal = 0, cruise_time = 0;
  size_t cruise_steps = 0;
  for (size_t i = 0; i + 1 < s.size(); ++i) {
    const double dt = double(s[i + 1].rise_cycle - s[i].rise_cycle) / t.f_cpu_hz;
    const double done = double(i + 1), left = double(steps) - done;
    const double want = std::min(vmax, std::floor(std::sqrt(v0 * v0 + 2 * a * (std::min(done, left) - 1))));
    const double err = (1.0 / dt - want) / want;
    worst = std::max(worst, std::fabs(err));
    sum_err += std::fabs(err);
    took += dt;
    ideal += 1.0 / want;
    if (want == vmax) cruise_time += dt, ++cruise_steps;
  }
  const double cruise = double(cruise_steps) / cruise_time;
  std::printf("jog ramp: %lld steps in %.4f s (the ramp's %.4f s), %zu steps at %.2f steps/s (%.0f asked), speed "
              "error per step: worst %.3f %%, mean %.4f %%\n",
              (long long)steps, took, ideal, cruise_steps, cruise, vmax, 100 * worst, 100 * sum_err / double(s.size() - 1));
  CHECK(std::fabs(took - ideal) / ideal < 0.002);
  CHECK(cruise_steps == size_t(steps - 1 - 2 * 315));  // 315 steps up to speed (2an = vmax^2 - v0^2), as many down
  CHECK(cruise == Approx(vmax).epsilon(0.0005));
  CHECK(sum_err / double(s.size() - 1) < 0.002);
  CHECK(worst < 0.08);  // (the speed of a step lags by one where the main loop was late)
}

TEST_CASE("jog by millimetres and turns, then center: the board counts the carriage from the middle declared",
          "[play][pacing]") {
  const std::string trace_path = scratch("center.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // 80 steps/mm, 400 steps a turn.
  const std::string config = motion_config("center", vb.pty(), "steps_per_mm = 80.0\nsteps_per_turn = 400.0\n");
  const auto run = [&](std::vector<std::string> args) {
    int status = -1;
    args.insert(args.end(), {"--port", vb.pty(), "--config", config, "--motor", "2"});
    const std::string out = run_stepchoir(args, &status);
    INFO(out);
    CHECK(status == 0);
    return out;
  };
  // From the rail's middle (the firmware's count starts there): 10 mm up, a turn back.
  CHECK(run({"jog", "--mm", "10"}).find("moved 800 steps (10.0 mm), position 2400") != std::string::npos);
  CHECK(run({"jog", "--turns", "-1"}).find("moved 400 steps (5.0 mm), position 2000") != std::string::npos);
  // The user sees the carriage 400 steps off the middle, and declares it the middle anyway.
  CHECK(run({"center"}).find("motor 2: the carriage is the middle of its rail, position 1600") != std::string::npos);
  // The board now counts from there: 5 mm down ends at 1200, where it counted 1600 before.
  CHECK(run({"jog", "--mm", "-5"}).find("moved 400 steps (5.0 mm), position 1200") != std::string::npos);
  REQUIRE(vb.stop() == 0);
  // The carriage itself (the virtual board's rail): 800 up, 400 and 400 back, 800 steps all.
  const tr::Trace t = tr::read_trace(trace_path);
  CHECK(t.motor[2].steps.size() == 1600u);
  CHECK(final_position(t, 2, kTravel / 2) == kTravel / 2);
}

TEST_CASE("home_on_start: play and jam home the switched carriages all at once, then play the song", "[play][pacing]") {
  const std::string command = GENERATE(as<std::string>{}, "play", "jam");
  INFO(command);
  const std::string trace_path = scratch("home-" + command + ".csv");
  VboardProcess vb({"--board", "mega", "--trace", trace_path, "--quiet", "--no-measure", "--start-position", "0"});
  const std::string top = motion_config("home-" + command, vb.pty(), "home_speed = 60.0\n", "home_on_start = true\n");
  const std::string song = write_test_song("home-" + command + ".mid");
  // The song at twice its tempo: what matters here is that it comes after the homing.
  std::vector<std::string> args{command, song, "--tempo", "2", "--port", vb.pty(), "--config", top, "--quiet"};
  // Jam: the song on motors 0 and 1, a JACK keyboard (silent) on the others.
  std::unique_ptr<JackServer> jack;
  std::unique_ptr<Sender> keys;
  if (command == "jam") {
    jack = std::make_unique<JackServer>(1024);
    keys = std::make_unique<Sender>();
    args.insert(args.end(), {"--midi-api", "jack", "--midi", Sender::kPort, "--song-motors", "0,1"});
  }
  int status = -1;
  const std::string out = run_stepchoir(args, &status);
  INFO(out);
  REQUIRE(status == 0);
  REQUIRE(vb.stop() == 0);
  const tr::Trace t = tr::read_trace(trace_path);
  // The three motors home at once: each starts before any has ended its homing.
  uint64_t latest_start = 0, earliest_end = UINT64_MAX;
  for (int m = 0; m < 3; ++m) {
    INFO("motor " << m);
    CHECK(out.find("motor " + std::to_string(m) + ": in the middle, position 1600") != std::string::npos);
    // Homing's last move ends in the middle; the song's first step comes after it.
    const auto &s = t.motor[size_t(m)].steps;
    size_t last_home = 0;
    while (last_home + 1 < s.size() && s[last_home + 1].rise_cycle - s[last_home].rise_cycle < t.f_cpu_hz / 10)
      ++last_home;  // the homing moves follow each other within 100 ms
    REQUIRE(last_home < s.size());
    bool reached_max = false;
    for (size_t i = 0; i <= last_home; ++i) reached_max = reached_max || s[i].position == kTravel;
    CHECK(reached_max);
    CHECK(s[last_home].position == kTravel / 2);
    if (m < 2) CHECK(last_home + 1 < s.size());  // the song's steps follow (motors 0 and 1 play it)
    latest_start = std::max(latest_start, s.front().rise_cycle);
    earliest_end = std::min(earliest_end, s[last_home].rise_cycle);
  }
  CHECK(latest_start < earliest_end);
  CHECK(out.find("motor 3 has no end switch: not homed") != std::string::npos);
}

// test_rig.cpp: one rig file for every command. With the file at its default location
// ($XDG_CONFIG_HOME/stepchoir/stepchoir.toml) and no --port or --config, `stepchoir hello`
// finds the board it names, and `stepchoir play` configures its motors before the first note
// (a TB6600's 5 us pulses) and plans the song with their musical settings (a motor an octave
// up), on the real firmware.
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "analysis.h"
#include "config/rig.h"
#include "play_checks.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
namespace tr = sc::trace;

TEST_CASE("rig: from its default location the file names the board for hello and play, and play configures "
          "a TB6600 motor an octave up",
          "[play][pacing]") {
  const std::string trace_path = scratch("rig.csv"), home = scratch("rig-config");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  ::mkdir(home.c_str(), 0700);
  ::mkdir((home + "/stepchoir").c_str(), 0700);
  const std::string file = home + "/stepchoir/stepchoir.toml";
  std::ofstream(file) << "[[boards]]\nport = \"" << vb.pty() << "\"\n"
                      << "[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 5\ntranspose = 12\n";
  ::setenv("XDG_CONFIG_HOME", home.c_str(), 1);  // the children read it
  struct Restore {
    ~Restore() { ::unsetenv("XDG_CONFIG_HOME"); }
  } restore;

  int status = -1;
  const std::string where = run_stepchoir({"config", "--where"}, &status);
  CHECK(status == 0);
  CHECK(where == file + "\n");
  const std::string hello = run_stepchoir({"hello"}, &status);
  INFO(hello);
  REQUIRE(status == 0);
  CHECK(hello.find("board: uno") != std::string::npos);

  const std::string song = write_test_song("rig.mid");
  const std::string out = run_stepchoir({"play", song, "--quiet"}, &status);
  INFO(out);
  REQUIRE(status == 0);
  CHECK(out.find("no --port") == std::string::npos);  // the rig's board, not a virtual one of its own
  CHECK(out.find("late 0,") != std::string::npos);
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  REQUIRE(t.motors == 4);
  const Rig rig = load_rig(file);
  PlanOptions o;
  std::vector<uint8_t> ids{0, 1, 2, 3};
  o.motors = motor_music(board_settings(rig, vb.pty(), 0), t.f_cpu_hz, ids);
  REQUIRE(o.motors[0].transpose == 12);
  const Plan plan = plan_song(read_song_file(song), o);
  size_t on_motor0 = 0;
  for (const PlannedNote &n : plan.notes) on_motor0 += n.motor == 0;
  REQUIRE(on_motor0 > 0);  // the transposed motor plays
  // every planned note, motor 0's an octave up, on time and in tune (the untransposed plan
  // would put motor 0's notes 12 semitones off)
  check_song("play, rig file", t, plan);
  // The TB6600's 5 us pulse, configured before the first note (motor 1: the file's default).
  check_tb6600_pulses(t, 0, 1);
  ::unlink(file.c_str());
}

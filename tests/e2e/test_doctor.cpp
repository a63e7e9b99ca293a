// test_doctor.cpp: `stepchoir doctor` against virtual boards: the configuration's first mistake
// with its line and column, each board's hello and firmware, and a round trip that a 16 ms
// FTDI bridge makes slow, each with its fix.
#include <catch2/catch.hpp>

#include <fstream>
#include <string>

#include "play_checks.h"
#include "stepchoir_protocol.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;

TEST_CASE("doctor: a configuration mistake is named with its line, column and fix", "[play]") {
  const std::string file = scratch("doctor-bad.toml");
  std::ofstream(file) << "a4_hz = 440.0\n[[boards]]\nport = \"" << scratch("doctor-no-board") << "\"\n"
                      << "[[boards.motors]]\nmicrosteps = 3\n";
  int status = -1;
  const std::string out = run_stepchoir_all({"doctor", "--config", file}, &status);
  INFO(out);
  CHECK(status == 1);
  CHECK(out.find("FIX  configuration: " + file + ":5:14: microsteps must be 1, 2, 4, 8, 16 or 32\n     edit that line") !=
        std::string::npos);
}

TEST_CASE("doctor: each board's firmware and round trip, a slow bridge with its fix", "[play][pacing]") {
  VboardProcess fast({"--board", "uno", "--quiet", "--no-measure"});
  VboardProcess slow({"--board", "mega", "--quiet", "--no-measure", "--link-model", "ftdi"});
  const std::string file = scratch("doctor.toml");
  std::ofstream(file) << "[[boards]]\nport = \"" << fast.pty() << "\"\n[[boards]]\nport = \"" << slow.pty() << "\"\n";
  int status = -1;
  const std::string out = run_stepchoir_all({"doctor", "--config", file}, &status);
  INFO(out);
  CHECK(status == 1);  // the slow bridge at least
  CHECK(out.find("ok   configuration: " + file + " (2 boards)") != std::string::npos);
  CHECK(out.find("ok   " + fast.pty() + ": readable and writable") != std::string::npos);
  const std::string protocol = ", protocol " + std::to_string(sc::kProtocolVersion);  // the host's own: no mismatch
  CHECK(out.find("ok   " + fast.pty() + ": uno_cnc_shield_v3, 4 motors" + protocol) != std::string::npos);
  CHECK(out.find("ok   " + fast.pty() + ": round trip p50 ") != std::string::npos);  // the 16U2: about 4 ms
  CHECK(out.find("ok   " + slow.pty() + ": mega_ramps_14, 5 motors" + protocol) != std::string::npos);
  CHECK(out.find("FIX  " + slow.pty() + ": round trip p50 ") != std::string::npos);  // the FTDI's 16 ms
  CHECK(out.find("latency_timer") != std::string::npos);
  CHECK(out.find("real time: ") != std::string::npos);
  CHECK(out.find("MIDI (alsa)") != std::string::npos);
}

// test_vboard.cpp: the virtual board's own debugging aids, on the real firmware.
#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "e2e_util.h"
#include "pitch.h"
#include "trace.h"

using namespace stepchoir;

TEST_CASE("vboard: the PC trace is written each time a watched RAM byte changes - ending on the write") {
  // Watch PORTD (data address 0x2B on the ATmega328P): STEP X is D2 and DIR X D5, so the
  // note's DIR and every rise and fall of motor 0's STEP change it. Each dump must end right
  // after the instruction that made the change (a step is recorded before it runs, and the byte
  // compared after): its last line is 1-4 cycles after a DIR change or STEP edge of the trace.
  const std::string base = e2e::scratch("pctrace-watch");
  for (int i = 1; i <= 4; ++i) std::remove((base + "." + std::to_string(i)).c_str());
  const std::string trace_path = e2e::scratch("pctrace-watch.csv");
  setenv("STEPCHOIR_VBOARD_PCTRACE", base.c_str(), 1);
  setenv("STEPCHOIR_VBOARD_PCTRACE_WATCH", "0x2B", 1);
  setenv("STEPCHOIR_VBOARD_PCTRACE_AFTER", "8000000", 1);  // past boot (0.5 s)
  setenv("STEPCHOIR_VBOARD_PCTRACE_MAX", "3", 1);
  // 3 s: the host connects up to about 1 s in, and the tone must run a while after that.
  VboardProcess vb({"--board", "uno", "--seconds", "3", "--trace", trace_path, "--quiet"});
  for (const char *v : {"STEPCHOIR_VBOARD_PCTRACE", "STEPCHOIR_VBOARD_PCTRACE_WATCH", "STEPCHOIR_VBOARD_PCTRACE_AFTER",
                        "STEPCHOIR_VBOARD_PCTRACE_MAX"})
    unsetenv(v);
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  b.send(periods_payload({{0, hz_to_period_q8(200.0, caps.f_cpu_hz)}}));
  REQUIRE(vb.wait() == 0);
  const auto t = sc::trace::read_trace(trace_path);
  REQUIRE(t.motor.at(0).steps.size() > 10);
  for (int i = 1; i <= 3; ++i) {
    INFO("dump " << i);
    std::ifstream in(base + "." + std::to_string(i));
    REQUIRE(in);
    std::vector<unsigned long> cycles;
    unsigned long cycle, pc, flag;
    while (in >> cycle >> std::hex >> pc >> std::dec >> flag) cycles.push_back(cycle);
    CHECK(cycles.size() == 65536);
    REQUIRE(!cycles.empty());
    CHECK(cycles.back() >= 8000000ul);
    std::vector<uint64_t> changes;
    for (const auto &s : t.motor.at(0).steps) {
      changes.push_back(s.rise_cycle);
      changes.push_back(s.rise_cycle + s.width_cycles);
    }
    for (const auto &d : t.motor.at(0).dir_changes) changes.push_back(d.cycle);
    bool after_change = false;
    for (uint64_t e : changes)
      if (cycles.back() > e && cycles.back() - e <= 4) after_change = true;
    CHECK(after_change);
  }
  std::ifstream fourth(base + ".4");
  CHECK(!fourth);  // STEPCHOIR_VBOARD_PCTRACE_MAX
}

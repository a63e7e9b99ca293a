// test_vboard.cpp: the virtual board's own debugging aids, on the real firmware.
#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/pitch.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;

TEST_CASE("vboard: the PC trace is written each time a watched RAM byte changes - ending on the write") {
  // Watch PORTD (data address 0x2B on the ATmega328P): STEP and DIR of motors 0-2 (X, Y, Z on
  // D2-D7), so their DIR settings at boot and at the note's onset and every rise and fall of
  // motor 0's STEP change it. Each dump must end right after the instruction that made the
  // change (a step is recorded before it runs, the byte compared after): its last line is 1-4
  // cycles after one of those changes in the trace. (No start cycle: when the host connects is
  // not known in advance; the first dumps are the boot's DIR settings.)
  const int kDumps = 12;
  const std::string base = e2e::scratch("pctrace-watch");
  for (int i = 1; i <= kDumps + 1; ++i) {
    std::remove((base + "." + std::to_string(i)).c_str());
    std::remove((base + "." + std::to_string(i) + ".ram").c_str());
  }
  const std::string trace_path = e2e::scratch("pctrace-watch.csv");
  setenv("STEPCHOIR_VBOARD_PCTRACE", base.c_str(), 1);
  setenv("STEPCHOIR_VBOARD_PCTRACE_WATCH", "0x2B", 1);
  setenv("STEPCHOIR_VBOARD_PCTRACE_MAX", std::to_string(kDumps).c_str(), 1);
  VboardProcess vb({"--board", "uno", "--seconds", "2.5", "--trace", trace_path, "--quiet"});  // host in by ~1 s
  for (const char *v : {"STEPCHOIR_VBOARD_PCTRACE", "STEPCHOIR_VBOARD_PCTRACE_WATCH", "STEPCHOIR_VBOARD_PCTRACE_MAX"})
    unsetenv(v);
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  b.send(periods_payload({{0, hz_to_period_q8(200.0, caps.f_cpu_hz)}}));
  REQUIRE(vb.wait() == 0);
  const auto t = sc::trace::read_trace(trace_path);
  REQUIRE(t.motor.at(0).steps.size() > 10);
  std::vector<uint64_t> changes, step_rises;
  for (size_t m = 0; m < 3; ++m) {
    for (const auto &s : t.motor.at(m).steps) {
      changes.push_back(s.rise_cycle);
      changes.push_back(s.rise_cycle + s.width_cycles);
      if (m == 0) step_rises.push_back(s.rise_cycle);
    }
    for (const auto &d : t.motor.at(m).dir_changes) changes.push_back(d.cycle);
  }
  const auto just_after = [](uint64_t last, const std::vector<uint64_t> &events) {
    for (uint64_t e : events)
      if (last > e && last - e <= 4) return true;
    return false;
  };
  int after_step = 0;
  int last_portd = -1;
  for (int i = 1; i <= kDumps; ++i) {
    INFO("dump " << i);
    std::ifstream in(base + "." + std::to_string(i));
    REQUIRE(in);
    std::vector<unsigned long> cycles;
    unsigned long cycle, pc, flag;
    while (in >> cycle >> std::hex >> pc >> std::dec >> flag) cycles.push_back(cycle);
    CHECK(cycles.size() == 65536);
    REQUIRE(!cycles.empty());
    CHECK(just_after(cycles.back(), changes));
    after_step += just_after(cycles.back(), step_rises);
    // The RAM right after the change (PATH.N.ram, the ATmega328P's 2,304-byte data space):
    // every change is dumped, so PORTD differs from the dump before.
    std::ifstream ram(base + "." + std::to_string(i) + ".ram", std::ios::binary);
    REQUIRE(ram);
    const std::vector<char> data((std::istreambuf_iterator<char>(ram)), std::istreambuf_iterator<char>());
    REQUIRE(data.size() == 2304);
    const int portd = static_cast<unsigned char>(data[0x2B]);
    CHECK(portd != last_portd);
    last_portd = portd;
  }
  CHECK(after_step > 0);  // not only the boot's DIR settings: STEP edges too
  std::ifstream past_max(base + "." + std::to_string(kDumps + 1));
  CHECK(!past_max);  // STEPCHOIR_VBOARD_PCTRACE_MAX
}

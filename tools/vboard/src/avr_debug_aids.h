// avr_debug_aids.h: the run loop's debugging aids, STEPCHOIR_VBOARD_PCTRACE and STEPCHOIR_VBOARD_PCPROFILE.
#ifndef STEPCHOIR_VBOARD_AVR_DEBUG_AIDS_H
#define STEPCHOIR_VBOARD_AVR_DEBUG_AIDS_H

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

extern "C" {
#include <simavr/sim_avr.h>
}

#include "cpu_profiler.h"  // with_pid

namespace vboard {

// Cycles spent at each flash address, written at exit (see STEPCHOIR_VBOARD_PCPROFILE).
struct PcProfile {
  std::string path;
  std::vector<uint64_t> cycles;
  // Called from: run_until, once. Empty path: counts nothing.
  PcProfile(const char *p, size_t flash_bytes) : path(p ? p : ""), cycles(p ? flash_bytes : 0) {}
  // Called from: run_until, every step.
  void add(uint32_t pc_bytes, uint64_t n) {
    if (pc_bytes < cycles.size()) cycles[pc_bytes] += n;
  }
  // Writes the nonzero counts to path ("%p": the process id) at exit.
  ~PcProfile() {
    if (path.empty()) return;
    path = with_pid(path);
    if (FILE *f = std::fopen(path.c_str(), "w")) {
      for (size_t a = 0; a < cycles.size(); ++a)
        if (cycles[a]) std::fprintf(f, "%zx %llu\n", a, static_cast<unsigned long long>(cycles[a]));
      std::fclose(f);
    }
  }
};

// The last 65,536 instructions ("cycle pc I", see STEPCHOIR_VBOARD_PCTRACE), written when the
// core crashes or, with a watched RAM byte, each time that byte changes.
struct PcTrace {
  static constexpr size_t kSteps = 65536;  // a power of two: the ring index is masked
  std::string path;
  std::vector<std::array<uint32_t, 3>> ring;
  size_t next = 0;
  long watch = -1;         // RAM address watched, or -1
  uint64_t after = 0;      // watch from this cycle on
  int max_dumps = 20, dumps = 0;
  int last = -1;           // the watched byte's value at the previous step
  // Called from: run_until, once. Null path: records nothing.
  explicit PcTrace(const char *p) : path(p ? with_pid(p) : ""), ring(p ? kSteps : 0) {
    if (!p) return;
    if (const char *w = std::getenv("STEPCHOIR_VBOARD_PCTRACE_WATCH")) watch = std::strtol(w, nullptr, 0);
    if (const char *a = std::getenv("STEPCHOIR_VBOARD_PCTRACE_AFTER")) after = std::strtoull(a, nullptr, 0);
    if (const char *m = std::getenv("STEPCHOIR_VBOARD_PCTRACE_MAX")) max_dumps = std::atoi(m);
  }
  // Called from: run_until, every step. True when the watched byte changed: dump now.
  bool record(const avr_t *avr) {
    ring[next++ & (kSteps - 1)] = {static_cast<uint32_t>(avr->cycle), avr->pc, avr->sreg[S_I]};
    if (watch < 0 || watch > avr->ramend || dumps >= max_dumps) return false;
    const int v = avr->data[watch];
    const bool changed = last >= 0 && v != last && avr->cycle >= after;
    last = v;
    return changed;
  }
  // Called from: run_until, when record() said so. Writes PATH.1, PATH.2, ... and the RAM as it
  // is right after the change to PATH.1.ram, PATH.2.ram, ...
  void dump(const avr_t *avr) {
    const std::string file = path + "." + std::to_string(++dumps);
    write(file);
    write_ram(file + ".ram", avr);
  }
  // Writes the data space (registers, I/O, RAM: ramend + 1 bytes) to file.
  static void write_ram(const std::string &file, const avr_t *avr) {
    if (FILE *f = std::fopen(file.c_str(), "wb")) {
      std::fwrite(avr->data, 1, avr->ramend + 1, f);
      std::fclose(f);
    }
  }
  // Writes the ring to file, oldest first.
  void write(const std::string &file) const {
    if (FILE *f = std::fopen(file.c_str(), "w")) {
      for (size_t i = 0; i < kSteps; ++i) {
        const auto &e = ring[(next + i) & (kSteps - 1)];
        std::fprintf(f, "%u %x %u\n", e[0], e[1], e[2]);
      }
      std::fclose(f);
    }
  }
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_AVR_DEBUG_AIDS_H

// avr_run_loop.cpp: AvrAdapter::run_until: steps the core, feeding the CPU profiler and the debugging aids.
#include "avr_adapter.h"

#include <cstdint>
#include <cstdlib>

extern "C" {
#include <simavr/sim_avr.h>
}

#include "avr_debug_aids.h"

namespace vboard {

namespace {

// RETI opcode (little-endian word 0x9518).
inline bool is_reti(const uint8_t *flash, uint32_t pc_bytes) {
  return flash[pc_bytes] == 0x18 && flash[pc_bytes + 1] == 0x95;
}

// True when the core will not run any more.
inline bool core_stopped(int state) {
  return state == cpu_Done || state == cpu_Crashed || state == cpu_Stopped;
}

}  // namespace

// Runs until cycle >= end_cycle, the core stops or the bridge passes board bytes to the host
// (run_end_cycle_, which end_run_at_tx_pass lowers). With a profiler, every step is sampled.
CoreState AvrAdapter::run_until(uint64_t end_cycle) {
  avr_t *const avr = avr_;
  int state = avr->state;
  run_end_cycle_ = end_cycle;
  end_run_at_tx_pass();  // board bytes the bridge already holds
  if (!profiler_) {
    while (avr->cycle < run_end_cycle_ && !core_stopped(state)) state = avr_run(avr);
  } else {
    CpuProfiler &profiler = *profiler_;
    const uint8_t *const flash = avr->flash;
    InstructionSample s;
    // Debugging aid: STEPCHOIR_VBOARD_PCTRACE=PATH ("%p": the process id) keeps the last
    // PcTrace::kSteps steps ("cycle pc I") and writes them to PATH (and RAM to PATH.ram) when
    // the core crashes; with STEPCHOIR_VBOARD_PCTRACE_WATCH=ADDR also to PATH.1, PATH.2, ...
    // (RAM to PATH.1.ram, ...) each time the RAM byte at ADDR changes (docs/ARCHITECTURE.md, "Debugging aids").
    static PcTrace pc_trace(std::getenv("STEPCHOIR_VBOARD_PCTRACE"));
    // Debugging aid: STEPCHOIR_VBOARD_PCPROFILE=PATH counts the cycles spent at each flash
    // address and writes "address cycles" lines (hex, nonzero only) to PATH at exit ("%p" in
    // PATH becomes the process id); map them to functions with avr-addr2line or avr-objdump -d.
    static PcProfile pc_profile(std::getenv("STEPCHOIR_VBOARD_PCPROFILE"), avr->flashend + 1);
    const bool tracing = !pc_trace.path.empty();  // a register, not a load, every step
    while (avr->cycle < run_end_cycle_ && !core_stopped(state)) {
      if (tracing && pc_trace.record(avr)) pc_trace.dump(avr);
      s.pc_before_bytes = avr->pc;
      s.cycle_before = avr->cycle;
      s.i_before = avr->sreg[S_I] != 0;
      s.executed = state == cpu_Running;
      state = avr_run(avr);
      s.pc_after_bytes = avr->pc;
      s.cycle_after = avr->cycle;
      s.i_after = avr->sreg[S_I] != 0;
      s.was_reti = s.executed && profiler.in_isr() && is_reti(flash, s.pc_before_bytes);
      profiler.on_step(s);
      pc_profile.add(s.pc_before_bytes, s.cycle_after - s.cycle_before);
    }
    if (tracing && core_stopped(state)) {
      pc_trace.write(pc_trace.path);
      PcTrace::write_ram(pc_trace.path + ".ram", avr);
    }
  }
  if (state == cpu_Done) return CoreState::kDone;
  if (state == cpu_Crashed || state == cpu_Stopped) return CoreState::kCrashed;
  return CoreState::kRunning;
}

}  // namespace vboard

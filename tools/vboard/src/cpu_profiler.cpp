// cpu_profiler.cpp: interrupts-off windows and per-vector ISR statistics.
#include "cpu_profiler.h"

#include <cstdio>
#include <cstdlib>
#include <string>
#include <unistd.h>

namespace vboard {
std::string with_pid(std::string path) {
  const size_t pid_at = path.find("%p");
  if (pid_at != std::string::npos) path.replace(pid_at, 2, std::to_string(getpid()));
  return path;
}

namespace {
// Debugging aid: STEPCHOIR_VBOARD_IOFFLOG=PATH ("%p": the process id) writes every
// interrupts-off window after boot as "start_cycle start_pc_hex cycles" lines, to line late
// edges up with what held them (counted by start address and length, the same lines say what
// an edge due at a random moment waits behind).
struct IoffLog {
  FILE *file = nullptr;
  IoffLog() {
    if (const char *p = std::getenv("STEPCHOIR_VBOARD_IOFFLOG")) {
      file = std::fopen(with_pid(p).c_str(), "w");
    }
  }
  ~IoffLog() {
    if (file) std::fclose(file);
  }
};
IoffLog g_ioff_log;
}  // namespace

// Builds the flash-word -> ISR map from the ISR code ranges.
CpuProfiler::CpuProfiler(uint32_t flash_bytes, unsigned vector_count, unsigned vector_size_bytes,
                         const std::vector<IsrRange> &isrs)
    : vector_of_word_(flash_bytes / 2, 0),
      vector_size_bytes_(vector_size_bytes),
      vector_table_end_bytes_(vector_count * vector_size_bytes),
      stats_(vector_count) {
  for (unsigned v = 0; v < vector_count; ++v) stats_[v].vector = v;
  for (const IsrRange &isr : isrs) {
    if (isr.vector == 0 || isr.vector >= vector_count || isr.vector > 255) continue;
    stats_[isr.vector].has_symbol = true;
    for (uint32_t word = isr.start_bytes / 2; word < isr.end_bytes / 2 && word < vector_of_word_.size();
         ++word)
      vector_of_word_[word] = static_cast<uint8_t>(isr.vector);
  }
}

// Closes an interrupts-off window still open at the end of the run.
void CpuProfiler::finish(uint64_t cycle, bool i_flag) {
  if (!armed_) {
    boot_irq_off_cycles_ = cycle - reset_cycle_;  // interrupts were never enabled
    return;
  }
  if (i_flag) return;
  const uint64_t window_cycles = cycle - off_start_cycle_;
  if (window_cycles > irq_off_max_cycles_) {
    irq_off_max_cycles_ = window_cycles;
    irq_off_max_pc_bytes_ = off_start_pc_bytes_;
    irq_off_max_start_cycle_ = off_start_cycle_;
  }
}

// I went from set to clear: by an instruction (CLI, OUT SREG) or by taking an interrupt.
void CpuProfiler::irq_off_begin(const InstructionSample &s) {
  const bool vectored = s.pc_after_bytes < vector_table_end_bytes_ && s.pc_after_bytes != 0;
  off_start_pc_bytes_ = vectored ? s.pc_after_bytes : s.pc_before_bytes;
  off_start_cycle_ = vectored ? s.cycle_after : s.cycle_before;
}

// I went from clear to set: the window ends after the instruction that set it.
void CpuProfiler::irq_off_end(const InstructionSample &s) {
  if (!armed_) {
    armed_ = true;
    boot_irq_off_cycles_ = s.cycle_after - reset_cycle_;
    return;
  }
  const uint64_t window_cycles = s.cycle_after - off_start_cycle_;
  if (g_ioff_log.file)
    std::fprintf(g_ioff_log.file, "%llu %x %llu\n", static_cast<unsigned long long>(off_start_cycle_), off_start_pc_bytes_,
                 static_cast<unsigned long long>(window_cycles));
  if (window_cycles > irq_off_max_cycles_) {
    irq_off_max_cycles_ = window_cycles;
    irq_off_max_pc_bytes_ = off_start_pc_bytes_;
    irq_off_max_start_cycle_ = off_start_cycle_;
  }
}

// The core vectored to vector_slot_bytes at cycle.
void CpuProfiler::isr_enter(uint32_t vector_slot_bytes, uint64_t cycle) {
  const unsigned vector = vector_slot_bytes / vector_size_bytes_;
  ++stats_[vector].entries;
  if (depth_ == kMaxDepth) return;  // runaway nesting: count entries, stop timing
  stack_[depth_++] = {vector, cycle, 0, 0};
}

// RETI completed at cycle: closes the innermost invocation.
void CpuProfiler::isr_leave(uint64_t cycle) {
  const Invocation done = stack_[--depth_];
  const uint64_t total_cycles = cycle - done.entry_cycle;
  IsrStats &stats = stats_[done.vector];
  stats.inclusive_cycles += total_cycles - done.nested_cycles;
  if (total_cycles > stats.max_cycles) stats.max_cycles = total_cycles;
  if (done.irq_off_cycles > stats.max_irq_off_cycles) stats.max_irq_off_cycles = done.irq_off_cycles;
  if (depth_ != 0) {
    stack_[depth_ - 1].nested_cycles += total_cycles;
    stack_[depth_ - 1].irq_off_cycles += done.irq_off_cycles;
  }
}

}  // namespace vboard

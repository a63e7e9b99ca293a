// cpu_profiler.h: per-instruction accounting of interrupts-off windows and ISR time (pure logic).
#ifndef STEPCHOIR_VBOARD_CPU_PROFILER_H
#define STEPCHOIR_VBOARD_CPU_PROFILER_H

#include <cstdint>
#include <vector>
#include <string>

namespace vboard {

// "%p" in a debugging aid's path becomes the process id: one file per process when several run.
std::string with_pid(std::string path);

// An interrupt service routine's code range in flash (byte addresses, end exclusive).
struct IsrRange {
  unsigned vector;
  uint32_t start_bytes;
  uint32_t end_bytes;
};

// What one simulator step did; filled by the simulator adapter around each instruction.
struct InstructionSample {
  uint32_t pc_before_bytes;  // PC of the instruction (or of the sleeping core)
  uint32_t pc_after_bytes;   // PC after the step (a vector slot if an interrupt was taken)
  uint64_t cycle_before;
  uint64_t cycle_after;
  bool executed;             // the core ran an instruction (false while sleeping)
  bool was_reti;             // that instruction was RETI (only checked while inside an ISR)
  bool i_before;             // SREG.I before the step
  bool i_after;              // SREG.I after the step
};

// Statistics for one interrupt vector.
struct IsrStats {
  unsigned vector = 0;
  bool has_symbol = false;
  uint64_t entries = 0;             // times the vector was taken
  uint64_t body_cycles = 0;         // cycles with the PC inside the __vector_N function
  uint64_t inclusive_cycles = 0;    // entry to RETI, callees included, nested ISRs excluded
  uint64_t max_cycles = 0;          // longest invocation, entry to RETI, nested ISRs included
  uint64_t max_irq_off_cycles = 0;  // most cycles with I clear within one invocation
};

// Cycle accounting fed with every simulator step. An invocation starts when the core vectors
// (PC lands on the vector slot, after the interrupt response) and ends when its RETI completes.
// The interrupts-off window is measured from the instruction that cleared I (or the vector slot)
// to the end of the instruction that set it again; the boot window before the first SEI is
// reported on its own.
class CpuProfiler {
 public:
  // flash_bytes sizes the PC map; vector_count slots of vector_size_bytes each.
  CpuProfiler(uint32_t flash_bytes, unsigned vector_count, unsigned vector_size_bytes,
              const std::vector<IsrRange> &isrs);

  // True while an ISR invocation is open (the adapter then checks for RETI).
  bool in_isr() const { return depth_ != 0; }

  // Accounts one simulator step.
  inline void on_step(const InstructionSample &s);

  // The MCU was reset at cycle (the host's open, through DTR): no ISR runs any more, and the
  // windows until the first SEI are the boot's again.
  void on_reset(uint64_t cycle) {
    depth_ = 0;
    armed_ = false;
    reset_cycle_ = cycle;
  }

  // Closes an interrupts-off window still open at the end of the run.
  void finish(uint64_t cycle, bool i_flag);

  // Longest interrupts-off window after the first SEI, cycles.
  uint64_t irq_off_max_cycles() const { return irq_off_max_cycles_; }
  // PC (bytes) where that window started.
  uint32_t irq_off_max_pc_bytes() const { return irq_off_max_pc_bytes_; }
  // Cycle at which that window started.
  uint64_t irq_off_max_start_cycle() const { return irq_off_max_start_cycle_; }
  // Cycles from the last reset to the first SEI after it (the whole run if interrupts were
  // never enabled).
  uint64_t boot_irq_off_cycles() const { return boot_irq_off_cycles_; }
  // True once interrupts were enabled the first time.
  bool boot_done() const { return armed_; }
  // Per-vector statistics, indexed by vector number.
  const std::vector<IsrStats> &isr_stats() const { return stats_; }

 private:
  struct Invocation {
    unsigned vector;
    uint64_t entry_cycle;
    uint64_t nested_cycles;
    uint64_t irq_off_cycles;
  };
  static constexpr unsigned kMaxDepth = 32;

  // I went from set to clear.
  void irq_off_begin(const InstructionSample &s);
  // I went from clear to set.
  void irq_off_end(const InstructionSample &s);
  // The core vectored to vector_slot_bytes.
  void isr_enter(uint32_t vector_slot_bytes, uint64_t cycle);
  // RETI completed at cycle.
  void isr_leave(uint64_t cycle);

  std::vector<uint8_t> vector_of_word_;  // flash word -> vector whose body holds it (0 = none)
  uint32_t vector_size_bytes_;
  uint32_t vector_table_end_bytes_;
  std::vector<IsrStats> stats_;
  Invocation stack_[kMaxDepth];
  unsigned depth_ = 0;
  bool armed_ = false;
  uint64_t off_start_cycle_ = 0;
  uint32_t off_start_pc_bytes_ = 0;
  uint64_t irq_off_max_cycles_ = 0;
  uint32_t irq_off_max_pc_bytes_ = 0;
  uint64_t irq_off_max_start_cycle_ = 0;
  uint64_t boot_irq_off_cycles_ = 0;
  uint64_t reset_cycle_ = 0;
};

// Accounts one simulator step (hot path: a few compares unless something changed).
inline void CpuProfiler::on_step(const InstructionSample &s) {
  const uint64_t step_cycles = s.cycle_after - s.cycle_before;
  if (s.executed) {
    const uint32_t word = s.pc_before_bytes >> 1;
    if (word < vector_of_word_.size()) {
      const uint8_t vector = vector_of_word_[word];
      if (vector != 0) stats_[vector].body_cycles += step_cycles;
    }
  }
  if (depth_ != 0 && !s.i_before) stack_[depth_ - 1].irq_off_cycles += step_cycles;
  if (s.i_before != s.i_after) {
    if (s.i_after)
      irq_off_end(s);
    else
      irq_off_begin(s);
  }
  if (s.was_reti && depth_ != 0) isr_leave(s.cycle_after);
  if (s.pc_after_bytes < vector_table_end_bytes_ && s.pc_after_bytes != 0 &&
      s.pc_after_bytes != s.pc_before_bytes)
    isr_enter(s.pc_after_bytes, s.cycle_after);
}

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_CPU_PROFILER_H

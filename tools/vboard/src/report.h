// report.h: the end-of-run summary (stderr and "# summary" trace lines).
#ifndef STEPCHOIR_VBOARD_REPORT_H
#define STEPCHOIR_VBOARD_REPORT_H

#include <cstdint>
#include <string>
#include <vector>

#include "cpu_profiler.h"
#include "elf_symbols.h"
#include "virtual_board.h"

namespace vboard {

// Run-level facts gathered by main.
struct RunFacts {
  std::string end_reason;  // seconds | signal | done | crashed
  uint64_t end_cycle = 0;
  uint32_t f_cpu_hz = 16000000;
  unsigned vector_count = 0;       // interrupt vector slots, incl. reset
  unsigned vector_size_bytes = 4;  // bytes per slot
  bool pacing = true;
  double clock_ppm = 0;
  std::string link_model = "ideal";  // --link-model
  double wall_seconds = 0;
  uint64_t lag_max_ns = 0;
  uint64_t lag_max_cycle = 0;
  uint64_t slipped_ns = 0;
  uint64_t uart_in_bytes = 0;
  uint64_t uart_in_lost = 0;
  uint64_t host_resets = 0;  // resets by the host's open of the pty
  uint64_t uart_xoff_count = 0;
  uint64_t uart_would_overrun = 0;
  uint64_t uart_out_bytes = 0;
  uint64_t uart_dropped = 0;
  uint64_t host_bytes = 0;
  uint64_t line_dropped = 0, line_corrupted = 0, line_duplicated = 0;  // --line-* faults made
};

// Summary lines (without the "# summary " prefix). profiler may be null (--no-measure).
std::vector<std::string> summary_lines(const RunFacts &facts, const VirtualBoard &model,
                                       const CpuProfiler *profiler, const CodeSymbols &symbols);

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_REPORT_H

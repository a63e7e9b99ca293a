// report.cpp: formats the end-of-run summary lines.
#include "report.h"

#include <cstdio>
#include <sstream>

namespace vboard {

namespace {

// Fixed-point text of a real number.
std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

// Names a PC: "vector_slot_N" inside the vector table (an interrupt was just taken), else symbol+offset.
std::string describe_pc(uint32_t pc_bytes, const RunFacts &facts, const CodeSymbols &symbols) {
  if (facts.vector_size_bytes != 0 && pc_bytes < facts.vector_count * facts.vector_size_bytes)
    return "vector_slot_" + std::to_string(pc_bytes / facts.vector_size_bytes);
  return symbols.describe(pc_bytes);
}

}  // namespace

// Summary lines (without the "# summary " prefix).
std::vector<std::string> summary_lines(const RunFacts &facts, const VirtualBoard &model,
                                       const CpuProfiler *profiler, const CodeSymbols &symbols) {
  std::vector<std::string> lines = model.summary_lines();
  const double sim_seconds = static_cast<double>(facts.end_cycle) / facts.f_cpu_hz;
  if (profiler) {
    std::ostringstream irq;
    irq << "irq_off_max_cycles=" << profiler->irq_off_max_cycles()
        << " irq_off_max_at=" << describe_pc(profiler->irq_off_max_pc_bytes(), facts, symbols)
        << " irq_off_max_cycle=" << profiler->irq_off_max_start_cycle()
        << " irq_off_boot_cycles=" << profiler->boot_irq_off_cycles()
        << " sei_seen=" << (profiler->boot_done() ? 1 : 0);
    lines.push_back(irq.str());
    for (const IsrStats &isr : profiler->isr_stats()) {
      if (!isr.has_symbol && isr.entries == 0) continue;
      std::ostringstream text;
      const double load = facts.end_cycle ? static_cast<double>(isr.inclusive_cycles) / facts.end_cycle : 0;
      text << "isr=__vector_" << isr.vector << " entries=" << isr.entries
           << " cycles_total=" << isr.body_cycles << " cycles_inclusive=" << isr.inclusive_cycles
           << " max_cycles=" << isr.max_cycles << " max_irq_off_cycles=" << isr.max_irq_off_cycles
           << " load=" << fixed(load, 4) << (isr.has_symbol ? "" : " unhandled=1");
      lines.push_back(text.str());
    }
  } else {
    lines.push_back("measure=off");
  }
  std::ostringstream uart;
  uart << "uart_in=" << facts.uart_in_bytes << " uart_out=" << facts.uart_out_bytes
       << " uart_dropped=" << facts.uart_dropped << " uart_in_lost=" << facts.uart_in_lost

       << " uart_xoff=" << facts.uart_xoff_count << " uart_would_overrun=" << facts.uart_would_overrun
       << " host_bytes=" << facts.host_bytes << " line_dropped=" << facts.line_dropped
       << " line_corrupted=" << facts.line_corrupted << " line_duplicated=" << facts.line_duplicated;
  lines.push_back(uart.str());
  std::ostringstream run;
  run << "end=" << facts.end_reason << " sim_seconds=" << fixed(sim_seconds, 6)
      << " wall_seconds=" << fixed(facts.wall_seconds, 3) << " sim_mhz="
      << fixed(facts.wall_seconds > 0 ? facts.end_cycle / facts.wall_seconds / 1e6 : 0, 2)
      << " pacing=" << (facts.pacing ? "on" : "off") << " clock_ppm=" << facts.clock_ppm
      << " link_model=" << facts.link_model << " host_resets=" << facts.host_resets
      << " pacing_lag_max_us=" << facts.lag_max_ns / 1000
      << " pacing_lag_max_cycle=" << facts.lag_max_cycle << " pacing_slipped_us=" << facts.slipped_ns / 1000;
  lines.push_back(run.str());
  return lines;
}

}  // namespace vboard

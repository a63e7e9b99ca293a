// pacer.cpp: simulated-cycle to wall-clock mapping with lag accounting.
#include "pacer.h"

namespace vboard {

// f_cpu_hz nominal clock; clock_ppm crystal error (+ = fast); max_catchup_ns burst limit.
Pacer::Pacer(double f_cpu_hz, double clock_ppm, uint64_t max_catchup_ns)
    : cycles_per_second_(f_cpu_hz * (1.0 + clock_ppm / 1e6)), max_catchup_ns_(max_catchup_ns) {}

// Anchors cycle to wall_ns.
void Pacer::start(uint64_t cycle, uint64_t wall_ns) {
  anchor_cycle_ = cycle;
  anchor_wall_ns_ = wall_ns;
}

// Wall time (ns) at which cycle is due.
uint64_t Pacer::due_wall_ns(uint64_t cycle) const {
  const double elapsed_cycles = static_cast<double>(cycle - anchor_cycle_);
  return anchor_wall_ns_ + static_cast<uint64_t>(elapsed_cycles * 1e9 / cycles_per_second_);
}

// The cycle due at wall_ns (inverse of due_wall_ns; the anchor's cycle before the anchor).
uint64_t Pacer::cycle_at_wall_ns(uint64_t wall_ns) const {
  if (wall_ns <= anchor_wall_ns_) return anchor_cycle_;
  const double elapsed_ns = static_cast<double>(wall_ns - anchor_wall_ns_);
  return anchor_cycle_ + static_cast<uint64_t>(elapsed_ns * cycles_per_second_ / 1e9);
}

// Simulated time of cycle, ns from cycle 0.
uint64_t Pacer::sim_ns(uint64_t cycle) const {
  return static_cast<uint64_t>(static_cast<double>(cycle) * 1e9 / cycles_per_second_);
}

// The first cycle at or after simulated time ns (the double rounding corrected by a cycle).
uint64_t Pacer::cycle_at_sim_ns(uint64_t ns) const {
  uint64_t cycle = static_cast<uint64_t>(static_cast<double>(ns) * cycles_per_second_ / 1e9);
  while (cycle > 0 && sim_ns(cycle - 1) >= ns) --cycle;
  while (sim_ns(cycle) < ns) ++cycle;
  return cycle;
}

// How far the simulation is ahead of the wall clock; records lag and bounds catch-up.
int64_t Pacer::ahead_ns(uint64_t cycle, uint64_t wall_ns) {
  const int64_t ahead = static_cast<int64_t>(due_wall_ns(cycle) - wall_ns);
  if (ahead >= 0) return ahead;
  const uint64_t lag_ns = static_cast<uint64_t>(-ahead);
  if (lag_ns > lag_max_ns_) {
    lag_max_ns_ = lag_ns;
    lag_max_cycle_ = cycle;
  }
  if (lag_ns <= max_catchup_ns_) return ahead;
  const uint64_t give_up_ns = lag_ns - max_catchup_ns_;
  anchor_wall_ns_ += give_up_ns;
  slipped_ns_ += give_up_ns;
  return -static_cast<int64_t>(max_catchup_ns_);
}

// When host bytes read at wall_ns arrived, in simulated ns.
uint64_t host_arrival_ns(const Pacer &pacer, uint64_t wall_ns) { return pacer.sim_ns(pacer.cycle_at_wall_ns(wall_ns)); }

}  // namespace vboard

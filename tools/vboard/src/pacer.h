// pacer.h: maps simulated cycles to wall-clock time, with a bounded catch-up (pure logic).
#ifndef STEPCHOIR_VBOARD_PACER_H
#define STEPCHOIR_VBOARD_PACER_H

#include <cstdint>

namespace vboard {

// The board runs cycles_per_second (16 MHz, adjusted by the crystal's ppm error) of real time.
// When the simulation is ahead of the wall clock the caller sleeps; when it falls behind by more
// than max_catchup_ns, the pacer gives up the excess (the fast-forward stays bounded) and records it.
class Pacer {
 public:
  // f_cpu_hz nominal clock; clock_ppm crystal error (+ = fast); max_catchup_ns burst limit.
  Pacer(double f_cpu_hz, double clock_ppm, uint64_t max_catchup_ns);

  // Cycles the board executes per real second.
  double cycles_per_second() const { return cycles_per_second_; }
  // Anchors cycle to wall_ns.
  void start(uint64_t cycle, uint64_t wall_ns);
  // Wall time (ns) at which cycle is due.
  uint64_t due_wall_ns(uint64_t cycle) const;
  // The inverse of due_wall_ns: the cycle due at wall_ns (the anchor's cycle for an earlier wall
  // time).
  uint64_t cycle_at_wall_ns(uint64_t wall_ns) const;
  // Simulated time of cycle, ns from cycle 0: the host time the loop gives PtyLink::set_now_ns.
  uint64_t sim_ns(uint64_t cycle) const;
  // The inverse of sim_ns: the first cycle whose simulated time is ns or later (where the loop
  // ends a chunk so that a host byte reaches the UART when the bridge releases it).
  uint64_t cycle_at_sim_ns(uint64_t ns) const;
  // How far the simulation at cycle is ahead of wall_ns (negative = behind). Records the lag and,
  // beyond the catch-up limit, moves the anchor so at most max_catchup_ns remain to catch up.
  int64_t ahead_ns(uint64_t cycle, uint64_t wall_ns);
  // Largest lag seen, ns.
  uint64_t lag_max_ns() const { return lag_max_ns_; }
  // Simulated cycle at which the largest lag was seen.
  uint64_t lag_max_cycle() const { return lag_max_cycle_; }
  // Total wall time given up because the simulation could not keep up, ns.
  uint64_t slipped_ns() const { return slipped_ns_; }

 private:
  double cycles_per_second_;
  uint64_t max_catchup_ns_;
  uint64_t anchor_cycle_ = 0;
  uint64_t anchor_wall_ns_ = 0;
  uint64_t lag_max_ns_ = 0;
  uint64_t lag_max_cycle_ = 0;
  uint64_t slipped_ns_ = 0;
};

// Host time (simulated ns, as sim_ns) to stamp host bytes with that the loop read at wall_ns:
// when they arrived on the wall clock, mapped through the pacer. A simulation behind the wall
// clock takes them when it reaches that time, not before (the bridge holds them); one ahead of
// it takes them at once, up to its lead late. Called from: the vboard's loop when pacing, before
// PtyLink::poll_rx.
uint64_t host_arrival_ns(const Pacer &pacer, uint64_t wall_ns);

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_PACER_H

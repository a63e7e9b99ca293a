// coalescer.h: the latest state per motor of one board while its link is busy, pure.
#ifndef STEPCHOIR_HOST_LIVE_COALESCER_H
#define STEPCHOIR_HOST_LIVE_COALESCER_H

#include <array>
#include <cstddef>
#include <cstdint>

#include "stepchoir_protocol.h"

namespace stepchoir {

// One motor's new period, engine -> writer. event_us: arrival of the MIDI event behind it.
struct MotorUpdate {
  uint8_t motor;        // the board's own motor index
  uint32_t period_q8;   // ticks q8, 0 = silent
  uint64_t event_us;    // monotonic_us() of the MIDI event; 0: none (vibrato, glide): no latency sample
};

// The latest state per motor of one board, while the link is busy. Pure; owned by the holder of
// its board's link ownership (board_link.h).
// A motor that went silent and then got a new note before the silence was sent keeps both:
// the silence goes out first (take_silences), then the new note (take_latest), so a repeated
// note is struck again and a silence is never lost. Anything else is coalesced to its latest.
class Coalescer {
 public:
  static constexpr size_t kMaxMotors = sc::kMaxMotors;

  // Called from: the holder of the link ownership (and tests). Does not allocate.
  void add(const MotorUpdate &u) noexcept;
  // Writes the pending silences that a later note superseded (period 0 entries), at most
  // kMaxMotors; returns the count. Their event times go to event_us (may be null).
  size_t take_silences(sc::PeriodEntry *out, uint64_t *event_us) noexcept;
  // Writes every motor's latest pending state; returns the count.
  size_t take_latest(sc::PeriodEntry *out, uint64_t *event_us) noexcept;
  // Marks motors 0 .. motor_count-1 to be sent again with their latest state (the entries
  // carry event time 0: no MIDI event behind them). Called from: the writer thread.
  void refresh(size_t motor_count) noexcept;
  // The same for the listed motors only.
  void refresh(const uint8_t *motors, size_t n) noexcept;
  // After the board was replaced by a fresh (silent) one: every motor whose latest state is a
  // note becomes pending again, so take_latest restores what should be sounding.
  void board_restarted() noexcept;
  // Updates folded into a later one so far (never a silence).
  uint64_t coalesced() const noexcept { return coalesced_; }
  // True when something waits to be sent.
  bool pending() const noexcept;

 private:
  struct Slot {
    bool dirty = false;             // latest differs from what was taken last
    bool silence_first = false;     // a silence must go out before latest
    uint32_t latest = sc::kPeriodSilent;
    uint32_t sent = sc::kPeriodSilent;  // last period taken (the board starts silent)
    uint64_t latest_us = 0, silence_us = 0;
  };
  std::array<Slot, kMaxMotors> slots_{};
  uint64_t coalesced_ = 0;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_COALESCER_H

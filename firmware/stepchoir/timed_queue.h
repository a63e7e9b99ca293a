// timed_queue.h: the board's queue of timestamped set-period entries (kMsgAt), pure.
//
// The main loop fills it (hal::queue_at, entries in time order) and empties it (sched::poll),
// each entry cfg::kTakeTicks before its time, so that the motor starts or strikes exactly on
// its tick. No ISR touches it. The host tests include it (tests/firmware/test_motor.cpp).
#ifndef STEPCHOIR_TIMED_QUEUE_H
#define STEPCHOIR_TIMED_QUEUE_H

#include <stdint.h>

#include "config.h"

namespace sched {

struct AtSlot {
  uint32_t at;         // board time, ticks
  uint32_t period_q8;  // ticks q8, sc::kPeriodSilent = silence
  uint8_t motor;
};

// A ring of cfg::kQueueSize entries. Called from: the main loop only.
struct TimedQueue {
  AtSlot slot[cfg::kQueueSize];
  uint8_t used, put_idx, take_idx;

  // Appends an entry; the caller checked used < cfg::kQueueSize.
  void put(uint8_t motor, uint32_t period_q8, uint32_t at) {
    AtSlot &s = slot[put_idx];
    s.at = at;
    s.period_q8 = period_q8;
    s.motor = motor;
    put_idx = (uint8_t)(put_idx + 1 == cfg::kQueueSize ? 0 : put_idx + 1);
    ++used;
  }
  // The oldest entry; only while used > 0.
  const AtSlot &front() const { return slot[take_idx]; }
  void pop() {
    take_idx = (uint8_t)(take_idx + 1 == cfg::kQueueSize ? 0 : take_idx + 1);
    --used;
  }
  // Drops every entry (stop-all).
  void clear() {
    used = 0;
    take_idx = put_idx;
  }
  // Drops the entries of the motors whose bit is set in mask (kMsgSilence); the others keep
  // their order. At most cfg::kQueueSize moves of 9 bytes.
  void drop(uint8_t mask) {
    uint8_t from = take_idx, to = take_idx, kept = 0;
    for (uint8_t n = used; n; --n) {
      if (!(mask & (1u << slot[from].motor))) {
        if (to != from) slot[to] = slot[from];
        to = (uint8_t)(to + 1 == cfg::kQueueSize ? 0 : to + 1);
        ++kept;
      }
      from = (uint8_t)(from + 1 == cfg::kQueueSize ? 0 : from + 1);
    }
    put_idx = to;
    used = kept;
  }
};

// Whether the main loop takes the queue's oldest entry now, `ahead` ticks before its time:
// within cfg::kTakeTicks of it, unless its motor still holds a timed change (restrike_pending)
// and the entry is more than cfg::kStartLeadTicks away (that motor takes it once the pending
// change is its next edge).
inline bool take_entry_now(int32_t ahead, bool restrike_pending) {
  if (ahead > (int32_t)cfg::kTakeTicks) return false;
  return !(restrike_pending && ahead > (int32_t)cfg::kStartLeadTicks);
}

}  // namespace sched

#endif  // STEPCHOIR_TIMED_QUEUE_H

// event_log.h: the latest MIDI events the live engine applied, for displays (the console's
// "last events"): a lock-free ring that one thread writes and any thread reads.
//
// Contract: record() from one thread only (the engine thread), never blocking, allocating or
// locking: one relaxed load, two stores. latest() from any thread, as often as it likes; it
// never makes the writer wait, and skips what the writer overwrote while it read. Each slot
// is one 64-bit word (a 16-bit sequence number, the three MIDI bytes, the time in ms modulo
// 2^24, about 4.6 hours), so a read is never torn.
#ifndef STEPCHOIR_HOST_LIVE_EVENT_LOG_H
#define STEPCHOIR_HOST_LIVE_EVENT_LOG_H

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "core/midi_event.h"

namespace stepchoir {

class EventLog {
 public:
  static constexpr size_t kEvents = 16;  // the ring's size: the most latest() can return

  // One event as latest() returns it.
  struct Entry {
    uint8_t status = 0, data1 = 0, data2 = 0;
    uint64_t age_ms = 0;  // how long before latest()'s now_us the event arrived
  };

  // Called from: the engine thread alone, for every MIDI event it applies. Does not allocate,
  // lock or wait.
  void record(const MidiEvent &e) noexcept {
    const uint64_t n = count_.load(std::memory_order_relaxed);
    const uint64_t word = ((n + 1) & 0xFFFF) << 48 | uint64_t{e.status} << 40 | uint64_t{e.data1} << 32 |
                          uint64_t{e.data2} << 24 | (e.timestamp_us / 1000 & kTimeMask);
    slots_[n % kEvents].store(word, std::memory_order_relaxed);
    count_.store(n + 1, std::memory_order_release);
  }

  // Writes the newest events first to out, up to max; returns how many. now_us: the clock
  // the events were stamped with (monotonic_us). Called from: any thread. Does not allocate.
  size_t latest(Entry *out, size_t max, uint64_t now_us) const noexcept {
    const uint64_t n = count_.load(std::memory_order_acquire);
    size_t got = 0;
    for (uint64_t i = n; i > 0 && got < max && n - i < kEvents; --i) {
      const uint64_t word = slots_[(i - 1) % kEvents].load(std::memory_order_acquire);
      if ((word >> 48) != (i & 0xFFFF)) break;  // overwritten by a newer event meanwhile
      const uint64_t when_ms = word & kTimeMask;
      out[got++] = Entry{static_cast<uint8_t>(word >> 40), static_cast<uint8_t>(word >> 32),
                         static_cast<uint8_t>(word >> 24), (now_us / 1000 - when_ms) & kTimeMask};
    }
    return got;
  }

  // Events recorded so far. Called from: any thread.
  uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }

 private:
  static constexpr uint64_t kTimeMask = (uint64_t{1} << 24) - 1;
  std::array<std::atomic<uint64_t>, kEvents> slots_{};
  std::atomic<uint64_t> count_{0};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_EVENT_LOG_H

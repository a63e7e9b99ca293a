// board_link.cpp: one board's writer and reader threads and its one send path (board_link.h).
#include "live/board_link.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <exception>

#include "board/board.h"
#include "live/midi_in.h"
#include "live/rt_guard.h"

namespace stepchoir {

using Clock = std::chrono::steady_clock;

// Called from: the writer thread. Takes a board's link ownership, waiting (yielding) while the
// engine holds it for one write; gives it back when it goes out of scope. Does not allocate.
class LinkOwnership {
 public:
  explicit LinkOwnership(BoardLink &b) noexcept : b_(b) {
    while (b_.owned_.exchange(true, std::memory_order_acquire)) std::this_thread::yield();
  }
  ~LinkOwnership() { b_.owned_.store(false, std::memory_order_release); }
  LinkOwnership(const LinkOwnership &) = delete;
  LinkOwnership &operator=(const LinkOwnership &) = delete;

 private:
  BoardLink &b_;
};

namespace {

// Called from: the engine and writer threads as they start. Asks for real-time scheduling
// (SCHED_FIFO), so that a busy machine does not delay their wake-ups; without the privilege
// the thread keeps normal scheduling. Returns whether it got it.
bool make_realtime(int priority) noexcept {
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
}

// Called from: the owner, right after a set-period frame went out. Each entry's MIDI event ->
// write() latency, and the latest such entry's two ends in the stats; refreshes (event time 0)
// are no MIDI event's.
void record_latency(LatencyHistogram &latency, BoardStats &stats, const uint64_t *event_us, size_t n) noexcept {
  const uint64_t now = monotonic_us();
  for (size_t i = 0; i < n; ++i) {
    if (event_us[i] == 0) continue;
    latency.record(now > event_us[i] ? now - event_us[i] : 0);
    stats.last_event_us.store(event_us[i], std::memory_order_relaxed);
    stats.last_written_us.store(now, std::memory_order_relaxed);
  }
}

}  // namespace

BoardLink::BoardLink(const LiveBoard &board, LatencyHistogram &latency, std::atomic<int> &realtime, int refresh_ms)
    : board_(board), latency_(latency), realtime_(realtime), refresh_ms_(refresh_ms) {
  link_.store(board.link);
}

void BoardLink::assert_owned() const noexcept {
#ifdef STEPCHOIR_RT_GUARD
  if (!owned_.load(std::memory_order_relaxed)) std::terminate();
#endif
}

bool BoardLink::attached() const noexcept {
  return detach_gen_.load(std::memory_order_acquire) == attach_gen_.load(std::memory_order_acquire);
}

// The one send path: every byte for the board goes out here, is counted and is charged to the
// budget. nonblocking: Link::try_write (the engine), else Link::write (may block). A failed
// blocking write marks the link failed. Does not allocate.
bool BoardLink::send_wire(Link &link, const uint8_t *wire, uint8_t len, bool nonblocking) {
  assert_owned();
  bool ok = false;
  try {
    ok = nonblocking ? link.try_write(wire, len) : link.write(wire, len);
  } catch (...) {
  }
  if (!ok) {
    if (!nonblocking) stats_.write_failed.store(true, std::memory_order_relaxed);
    return false;
  }
  stats_.frames_sent.fetch_add(1, std::memory_order_relaxed);
  stats_.bytes_sent.fetch_add(len, std::memory_order_relaxed);
  budget_.spend(len);
  return true;
}

// Encodes a payload and sends it (blocking). Called from: the owner.
bool BoardLink::send_payload(Link &link, const uint8_t *payload, uint8_t len) {
  uint8_t wire[sc::kMaxFrameWire];
  const uint8_t n = sc::encode_frame(payload, len, wire);
  return n != 0 && send_wire(link, wire, n, false);
}

void BoardLink::start() {
  {
    LinkOwnership own(*this);
    uint8_t wd[3] = {sc::kMsgWatchdog, 0, 0};
    sc::put_u16(&wd[1], sc::kWatchdogDefaultMs);  // the motors stop by themselves if this program dies
    send_payload(*link_.load(), wd, sizeof wd);
  }
  stats_.heard_us.store(monotonic_us());
  reader_ = std::thread([this] { reader_loop(); });
  writer_ = std::thread([this] { writer_loop(); });
}

void BoardLink::request_stop_writer() { stop_writer_.store(true); }

void BoardLink::join_writer() {
  if (writer_.joinable()) writer_.join();
}

void BoardLink::request_stop_reader() { stop_reader_.store(true); }

void BoardLink::join_reader() {
  if (reader_.joinable()) reader_.join();
}

bool BoardLink::detach(int timeout_ms) {
  const uint32_t gen = detach_gen_.load() + 1;
  detach_gen_.store(gen, std::memory_order_release);
  const auto end = Clock::now() + std::chrono::milliseconds(timeout_ms);
  while (writer_parked_gen_.load(std::memory_order_acquire) != gen ||
         reader_parked_gen_.load(std::memory_order_acquire) != gen) {
    if (Clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

void BoardLink::attach(Link *link) {
  link_.store(link, std::memory_order_release);
  board_.link = link;
  stats_.write_failed.store(false);
  stats_.read_failed.store(false);
  stats_.restarted.store(false);
  stats_.last_status_us.store(0);
  stats_.heard_us.store(monotonic_us());
  stats_.reconnects.fetch_add(1);
  attach_gen_.store(detach_gen_.load(), std::memory_order_release);
}

void BoardLink::post(const MotorUpdate &u) {
  if (song_motors_.load(std::memory_order_acquire) >> u.motor & 1) return;  // the song's now
  if (try_send_now(u)) return;
  while (!updates_.try_enqueue(u)) std::this_thread::yield();
  ++enqueued_;
}

// Called from: the engine thread (post). Writes u's frame at once when the link is idle: the
// engine got the ownership without waiting, the writer has taken every update queued before
// (so u cannot overtake one), nothing waits in the coalescer, the link is attached and has not
// failed, the budget has room, and the OS takes the frame without waiting (Link::try_write).
// False: nothing was written, the caller queues u for the writer.
bool BoardLink::try_send_now(const MotorUpdate &u) {
  if (owned_.exchange(true, std::memory_order_acquire)) return false;
  bool done = false;
  if (absorbed_.load(std::memory_order_acquire) == enqueued_ && !coalescer_.pending() && attached() &&
      !stats_.write_failed.load(std::memory_order_relaxed)) {
    budget_.refill(monotonic_us());
    Coalescer next = coalescer_;  // taken over only once the frame is written
    next.add(u);
    sc::PeriodEntry e[Coalescer::kMaxMotors];
    uint64_t event_us[Coalescer::kMaxMotors];
    const size_t silences = next.take_silences(e, event_us);  // none: the coalescer was idle
    const size_t n = silences ? 0 : next.take_latest(e, event_us);
    if (silences == 0 && n == 0) {  // nothing to send (a silence to a silent motor)
      coalescer_ = next;
      done = true;
    } else if (silences == 0 && n == 1 && budget_.can_send()) {
      uint8_t payload[sc::kSetPeriodBytes], wire[sc::kMaxFrameWire];
      sc::put_entry(payload, e[0].motor, e[0].period_q8);
      const uint8_t len = sc::encode_frame(payload, sizeof payload, wire);
      if (send_wire(*link_.load(std::memory_order_acquire), wire, len, true)) {
        record_latency(latency_, stats_, event_us, 1);
        coalescer_ = next;
        stats_.entries_sent.fetch_add(1, std::memory_order_relaxed);
        stats_.direct_frames.fetch_add(1, std::memory_order_relaxed);
        done = true;
      }
    }
  }
  owned_.store(false, std::memory_order_release);
  return done;
}

// Called from: the writer thread, owning the link. Writes the coalescer's pending silences,
// then its latest states, as set-period frames of up to kMaxPayload / kSetPeriodBytes entries.
void BoardLink::send_pending(Link &link) {
  sc::PeriodEntry entries[Coalescer::kMaxMotors];
  uint64_t event_us[Coalescer::kMaxMotors];
  for (int pass = 0; pass < 2; ++pass) {
    const size_t n = pass == 0 ? coalescer_.take_silences(entries, event_us) : coalescer_.take_latest(entries, event_us);
    const size_t per_frame = sc::kMaxPayload / sc::kSetPeriodBytes;
    for (size_t first = 0; first < n; first += per_frame) {
      const size_t count = std::min(per_frame, n - first);
      uint8_t payload[sc::kMaxPayload];
      for (size_t i = 0; i < count; ++i)
        sc::put_entry(&payload[i * sc::kSetPeriodBytes], entries[first + i].motor, entries[first + i].period_q8);
      if (!send_payload(link, payload, static_cast<uint8_t>(count * sc::kSetPeriodBytes))) continue;
      stats_.entries_sent.fetch_add(count, std::memory_order_relaxed);
      record_latency(latency_, stats_, event_us + first, count);
    }
  }
  stats_.coalesced.store(coalescer_.coalesced(), std::memory_order_relaxed);
}

// The writer thread. Budget per wake: drain the queue (tens of ns an update), encode at most
// two frames (< 1 us), then Link::write (a syscall; blocks while the OS buffer is full).
void BoardLink::writer_loop() {
  realtime_.fetch_add(make_realtime(kWriterPriority) ? 1 : 0);
  auto last_write = Clock::now(), last_status = Clock::now(), last_refresh = Clock::now();
  bool parked = false;
  for (;;) {
    RtScope rt;
    const bool stopping = stop_writer_.load(std::memory_order_acquire);
    // Sleep until an update comes, or until the budget allows what is pending, or 10 ms (1 ms
    // when a song player shares the link: its frames do not wake the writer).
    uint64_t wait_us;
    {
      LinkOwnership own(*this);
      budget_.refill(monotonic_us());
      wait_us = stopping               ? 0
                : coalescer_.pending() ? std::max<uint64_t>(budget_.wait_us(), 1)
                : song_.peek()         ? 500  // song frames wait for budget to spare
                : forward_             ? 1000  // a song player may queue a frame any moment (jam)
                                       : 10000;
    }
    MotorUpdate u;
    const bool woke = updates_.wait_dequeue_timed(u, std::chrono::microseconds(wait_us));
    LinkOwnership own(*this);
    if (woke) {
      uint64_t taken = 1;
      coalescer_.add(u);
      while (updates_.try_dequeue(u)) {
        coalescer_.add(u);
        ++taken;
      }
      absorbed_.fetch_add(taken, std::memory_order_release);
    } else if (stopping && !coalescer_.pending()) {
      break;
    }
    const uint32_t detached = detach_gen_.load(std::memory_order_acquire);
    if (detached != attach_gen_.load(std::memory_order_acquire)) {  // no link: collect only
      // The song player's frames were for the board that went away (its clock, its queue):
      // dropped, as sent into the void, so that its writes go on (jam: the song plays on and
      // finds the board again by its restarted clock).
      for (; song_.peek(); song_.pop()) {
        song_written_us_.store(0, std::memory_order_relaxed);  // when it left: unknown
        song_written_.fetch_add(1, std::memory_order_release);
      }
      writer_parked_gen_.store(detached, std::memory_order_release);
      parked = true;
      if (stopping) break;
      continue;
    }
    Link &link = *link_.load(std::memory_order_acquire);
    if (parked) {  // a new board: it starts silent, with its watchdog at the default
      parked = false;
      uint8_t wd[3] = {sc::kMsgWatchdog, 0, 0};
      sc::put_u16(&wd[1], sc::kWatchdogDefaultMs);
      send_payload(link, wd, sizeof wd);
      // A song's entries that reached it before the detach were timed on the old board's
      // clock: in the new board's queue they would wait for times that mean nothing there and
      // hold up the song's entries behind them. Dropped; the song's player restores what
      // sounds once it has synced again.
      if (const uint8_t song = song_motors_.load(std::memory_order_acquire)) {
        const uint8_t silence[2] = {sc::kMsgSilence, song};
        send_payload(link, silence, sizeof silence);
      }
      coalescer_.board_restarted();
    }
    if (Clock::now() - last_refresh >= std::chrono::milliseconds(refresh_ms_)) {
      uint8_t live[sc::kMaxMotors];  // the board's live motors less those a song plays
      size_t n = 0;
      const uint8_t song = song_motors_.load(std::memory_order_acquire);
      for (uint8_t m : board_.motors)
        if (!(song >> m & 1) && n < sc::kMaxMotors) live[n++] = m;
      coalescer_.refresh(live, n);
      last_refresh = Clock::now();
    }
    budget_.refill(monotonic_us());
    if (coalescer_.pending() && (budget_.can_send() || stopping)) {
      send_pending(link);
      last_write = Clock::now();
    }
    // Song frames (jam) go when no live update waits, within the budget and leaving it half a
    // burst to spare, so that a live note finds room at once.
    budget_.refill(monotonic_us());
    for (WireFrame *f = song_.peek();
         f && !coalescer_.pending() && budget_.credit_bytes() >= LinkBudget::kBurstBytes / 2 + f->len; f = song_.peek()) {
      if (!send_wire(link, f->bytes, f->len, false)) break;
      song_written_us_.store(monotonic_us(), std::memory_order_relaxed);
      song_written_.fetch_add(1, std::memory_order_release);
      song_.pop();
      last_write = Clock::now();
    }
    const auto now = Clock::now();
    if (now - last_write >= std::chrono::milliseconds(kHeartbeatMs)) {
      const uint8_t hb = sc::kMsgHeartbeat;
      if (send_payload(link, &hb, 1)) stats_.heartbeats.fetch_add(1, std::memory_order_relaxed);
      last_write = now;
    }
    if (now - last_status >= std::chrono::milliseconds(kStatusEveryMs)) {
      const uint8_t req = sc::kMsgStatusReq;
      send_payload(link, &req, 1);
      last_status = now;
    }
  }
  // Every motor got its silent entry from the engine's panic; stop-all also empties the board's
  // queue and turns the drivers off.
  RtScope rt;
  LinkOwnership own(*this);
  if (attached()) {
    const uint8_t stop_all = sc::kMsgStopAll;
    send_payload(*link_.load(), &stop_all, 1);
  }
}

bool BoardLink::queue_song_frame(const uint8_t *wire, size_t n) {
  if (n == 0 || n > sc::kMaxFrameWire) return false;
  WireFrame f;
  f.len = static_cast<uint8_t>(n);
  std::copy(wire, wire + n, f.bytes);
  if (!song_.try_enqueue(f)) return false;
  ++song_queued_;
  return true;
}

uint64_t BoardLink::song_frame_written_us(int timeout_ms) {
  const uint64_t until = monotonic_us() + static_cast<uint64_t>(timeout_ms) * 1000;
  while (song_written_.load(std::memory_order_acquire) < song_queued_) {
    if (monotonic_us() >= until) return 0;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  return song_written_us_.load(std::memory_order_relaxed);
}

long BoardLink::read_replies(uint8_t *out, size_t len, int timeout_ms) {
  if (partial_pos_ >= partial_.len) {
    if (!replies_.wait_dequeue_timed(partial_, std::chrono::milliseconds(timeout_ms))) return 0;
    partial_pos_ = 0;
  }
  const size_t n = std::min<size_t>(len, partial_.len - partial_pos_);
  std::copy(partial_.bytes + partial_pos_, partial_.bytes + partial_pos_ + n, out);
  partial_pos_ += n;
  return static_cast<long>(n);
}

// The reader thread: replies -> stats (errors, status, a restart). Not on the real-time path.
void BoardLink::reader_loop() {
  sc::FrameDecoder decoder;
  uint8_t buf[256];
  uint64_t last_pass = 0;
  while (!stop_reader_.load(std::memory_order_acquire)) {
    const uint32_t detached = detach_gen_.load(std::memory_order_acquire);
    if (detached != attach_gen_.load(std::memory_order_acquire)) {
      reader_parked_gen_.store(detached, std::memory_order_release);
      decoder = sc::FrameDecoder();
      last_pass = 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    // A pass long after the last (this thread held up) is not the board's silence.
    const uint64_t pass = monotonic_us();
    if (last_pass && pass > last_pass + kReaderGapUs)
      stats_.heard_us.fetch_add(pass - last_pass, std::memory_order_relaxed);
    last_pass = pass;
    stats_.read_us.store(pass, std::memory_order_release);  // after heard_us: repair_link reads it first
    long n = -1;
    try {
      n = link_.load(std::memory_order_acquire)->read(buf, sizeof buf, 50);
    } catch (...) {
    }
    if (n < 0) {
      stats_.read_failed.store(true, std::memory_order_relaxed);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    for (long i = 0; forward_ && i < n; i += sizeof(ReplyChunk::bytes)) {
      ReplyChunk c;
      c.len = static_cast<uint8_t>(std::min<long>(n - i, sizeof c.bytes));
      std::copy(buf + i, buf + i + c.len, c.bytes);
      replies_.try_enqueue(c);  // a player that stopped reading loses bytes, never blocks this
    }
    for (long i = 0; i < n; ++i) {
      if (decoder.push(buf[i]) != sc::kFrameOk) continue;
      stats_.heard_us.store(monotonic_us(), std::memory_order_relaxed);
      const uint8_t *p = decoder.payload();
      const uint8_t len = decoder.payload_len();
      if (p[0] == sc::kMsgError && len >= 4) {
        stats_.board_errors.fetch_add(1, std::memory_order_relaxed);
        stats_.last_error.store(p[1], std::memory_order_relaxed);
      } else if (sc::caps_announced(p, len)) {  // not a hello's answer: the board started again
        stats_.restarted.store(true, std::memory_order_relaxed);
      } else if (p[0] == sc::kMsgStatus) {
        try {
          const Status s = parse_status(p, len);
          stats_.status_frames_bad.store(s.head.frames_bad, std::memory_order_relaxed);
          stats_.status_overruns.store(s.head.uart_overruns, std::memory_order_relaxed);
          stats_.watchdog_tripped.store(s.head.flags & sc::kStatusWatchdogTripped, std::memory_order_relaxed);
          uint8_t sounding = 0, faults = 0;
          for (size_t m = 0; m < s.motors.size() && m < sc::kMaxMotors; ++m) {
            if (s.motors[m].flags & sc::kMotorSounding) sounding = static_cast<uint8_t>(sounding | (1u << m));
            if (s.motors[m].flags & sc::kMotorEndstopFault) faults = static_cast<uint8_t>(faults | (1u << m));
            stats_.position_steps[m].store(s.motors[m].position_steps, std::memory_order_relaxed);
            stats_.motor_reversals[m].store(s.motors[m].reversals, std::memory_order_relaxed);
          }
          stats_.sounding_mask.store(sounding, std::memory_order_relaxed);
          stats_.endstop_fault_mask.store(faults, std::memory_order_relaxed);
          stats_.reversals.store(s.head.reversals, std::memory_order_relaxed);
          stats_.last_status_us.store(monotonic_us(), std::memory_order_relaxed);
        } catch (const std::exception &) {
        }
      }
    }
  }
}

}  // namespace stepchoir

// session.cpp: the live session: engine, writer and reader threads, and the Coalescer.
#include "live/session.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "board/board.h"

namespace stepchoir {

// ---------------------------------------------------------------------------------------------
// Coalescer
// ---------------------------------------------------------------------------------------------

void Coalescer::add(const MotorUpdate &u) noexcept {
  if (u.motor >= kMaxMotors) return;
  Slot &s = slots_[u.motor];
  if (u.period_q8 == sc::kPeriodSilent) {
    if (s.dirty && s.latest != sc::kPeriodSilent) ++coalesced_;  // a note that never went out
    s.latest = sc::kPeriodSilent;
    s.latest_us = u.event_us;
    s.silence_first = false;  // the silence is now the latest state itself
    s.dirty = s.sent != sc::kPeriodSilent;
    return;
  }
  if (s.dirty && s.latest == sc::kPeriodSilent && s.sent != sc::kPeriodSilent) {
    s.silence_first = true;  // keep the silence: the new note must strike again
    s.silence_us = s.latest_us;
  } else if (s.dirty) {
    ++coalesced_;
  }
  s.latest = u.period_q8;
  s.latest_us = u.event_us;
  s.dirty = true;
}

size_t Coalescer::take_silences(sc::PeriodEntry *out, uint64_t *event_us) noexcept {
  size_t n = 0;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (!s.silence_first) continue;
    if (event_us) event_us[n] = s.silence_us;
    out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), sc::kPeriodSilent};
    s.sent = sc::kPeriodSilent;
    s.silence_first = false;
  }
  return n;
}

size_t Coalescer::take_latest(sc::PeriodEntry *out, uint64_t *event_us) noexcept {
  size_t n = 0;
  for (size_t m = 0; m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (!s.dirty) continue;
    if (s.silence_first) {  // take_silences was skipped: keep the order anyway
      if (event_us) event_us[n] = s.silence_us;
      out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), sc::kPeriodSilent};
      s.silence_first = false;
      continue;
    }
    if (event_us) event_us[n] = s.latest_us;
    out[n++] = sc::PeriodEntry{static_cast<uint8_t>(m), s.latest};
    s.sent = s.latest;
    s.dirty = false;
  }
  return n;
}

void Coalescer::refresh(size_t motor_count) noexcept {
  for (size_t m = 0; m < motor_count && m < kMaxMotors; ++m) {
    Slot &s = slots_[m];
    if (s.dirty || s.silence_first) continue;  // going out anyway
    s.dirty = true;
    s.latest_us = 0;
  }
}

void Coalescer::refresh(const uint8_t *motors, size_t n) noexcept {
  for (size_t i = 0; i < n; ++i) {
    if (motors[i] >= kMaxMotors) continue;
    Slot &s = slots_[motors[i]];
    if (s.dirty || s.silence_first) continue;
    s.dirty = true;
    s.latest_us = 0;
  }
}

void Coalescer::board_restarted() noexcept {
  for (Slot &s : slots_) {
    s.sent = sc::kPeriodSilent;
    s.silence_first = false;
    s.dirty = s.latest != sc::kPeriodSilent;
  }
}

bool Coalescer::pending() const noexcept {
  for (const Slot &s : slots_)
    if (s.dirty || s.silence_first) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// LinkBudget
// ---------------------------------------------------------------------------------------------

void LinkBudget::refill(uint64_t now_us) noexcept {
  if (last_us_ != 0 && now_us > last_us_) {
    const uint64_t elapsed_us = std::min<uint64_t>(now_us - last_us_, 10 * kMicro);  // no overflow
    credit_ = std::min(kBurstBytes * kMicro, credit_ + static_cast<int64_t>(elapsed_us) * kBytesPerSecond);
  }
  last_us_ = now_us;
}

uint64_t LinkBudget::wait_us() const noexcept {
  return credit_ >= 0 ? 0 : static_cast<uint64_t>((-credit_ + kBytesPerSecond - 1) / kBytesPerSecond);
}

// ---------------------------------------------------------------------------------------------
// LatencyHistogram
// ---------------------------------------------------------------------------------------------

void LatencyHistogram::record(uint64_t us) noexcept {
  bins_[us < kBins ? us : kBins - 1].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  uint64_t m = max_.load(std::memory_order_relaxed);
  while (us > m && !max_.compare_exchange_weak(m, us, std::memory_order_relaxed)) {
  }
}

uint64_t LatencyHistogram::percentile(double q) const noexcept {
  const uint64_t n = count();
  if (n == 0) return 0;
  const uint64_t rank = q <= 0 ? 1 : static_cast<uint64_t>(std::ceil(q * static_cast<double>(n)));
  uint64_t seen = 0;
  for (size_t i = 0; i < kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen >= rank) return i;
  }
  return kBins - 1;
}

// ---------------------------------------------------------------------------------------------
// LiveSession
// ---------------------------------------------------------------------------------------------

namespace {

using Clock = std::chrono::steady_clock;

// Called from: writer_loop (and start). Encodes a payload and writes it; counts it. Does not
// allocate; blocks in Link::write.
bool write_payload(Link &link, BoardStats &stats, const uint8_t *payload, uint8_t len) noexcept {
  uint8_t wire[sc::kMaxFrameWire];
  const uint8_t n = sc::encode_frame(payload, len, wire);
  if (n == 0) return false;
  bool ok = false;
  try {
    ok = link.write(wire, n);
  } catch (...) {
  }
  if (!ok) {
    stats.write_failed.store(true, std::memory_order_relaxed);
    return false;
  }
  stats.frames_sent.fetch_add(1, std::memory_order_relaxed);
  stats.bytes_sent.fetch_add(n, std::memory_order_relaxed);
  return true;
}

// Called from: writer_loop. One set-period frame for entries; records each entry's latency
// once write() returned. Does not allocate.
void write_entries(Link &link, BoardStats &stats, LatencyHistogram &latency, const sc::PeriodEntry *e,
                   const uint64_t *event_us, size_t n) noexcept {
  uint8_t payload[sc::kMaxPayload];
  const size_t per_frame = sc::kMaxPayload / sc::kSetPeriodBytes;
  for (size_t first = 0; first < n; first += per_frame) {
    const size_t count = std::min(per_frame, n - first);
    for (size_t i = 0; i < count; ++i)
      sc::put_entry(&payload[i * sc::kSetPeriodBytes], e[first + i].motor, e[first + i].period_q8);
    if (!write_payload(link, stats, payload, static_cast<uint8_t>(count * sc::kSetPeriodBytes))) continue;
    stats.entries_sent.fetch_add(count, std::memory_order_relaxed);
    const uint64_t now = monotonic_us();
    for (size_t i = 0; i < count; ++i)  // refreshes (event time 0) are no MIDI event's latency
      if (event_us[first + i] != 0) latency.record(now > event_us[first + i] ? now - event_us[first + i] : 0);
  }
}

// Called from: writer_loop. True when the budget would still hold half a burst after a song
// frame of len bytes (that half is kept for live notes).
bool song_room(const LinkBudget &budget, size_t len) noexcept {
  return budget.credit_bytes() >= LinkBudget::kBurstBytes / 2 + static_cast<int64_t>(len);
}

// Called from: the writer thread. Takes a board's link_owned flag, waiting (yielding) while
// the engine holds it for one write; gives it back when it goes out of scope. Does not allocate.
class LinkOwnership {
 public:
  explicit LinkOwnership(std::atomic<bool> &flag) noexcept : flag_(flag) {
    while (flag_.exchange(true, std::memory_order_acquire)) std::this_thread::yield();
  }
  ~LinkOwnership() { flag_.store(false, std::memory_order_release); }
  LinkOwnership(const LinkOwnership &) = delete;
  LinkOwnership &operator=(const LinkOwnership &) = delete;

 private:
  std::atomic<bool> &flag_;
};

// Called from: the engine and writer threads as they start. Asks for real-time scheduling
// (SCHED_FIFO), so that a busy machine does not delay their wake-ups; without the privilege
// the thread keeps normal scheduling. Returns whether it got it.
bool make_realtime(int priority) noexcept {
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
}

}  // namespace

AllocatorConfig pool_config(const std::vector<LiveBoard> &boards, Policy policy) {
  AllocatorConfig c;
  size_t total = 0;
  for (const LiveBoard &b : boards) {
    for (size_t m = 0; m < b.motor_count && total + m < Allocator::kMaxMotors; ++m)
      c.motors[total + m].f_cpu_hz = b.f_cpu_hz;
    total += b.motor_count;
  }
  if (total == 0 || total > Allocator::kMaxMotors)
    throw std::invalid_argument("the boards have " + std::to_string(total) + " motors in all; 1 to " +
                                std::to_string(Allocator::kMaxMotors) + " can play");
  c.motor_count = static_cast<uint8_t>(total);
  c.policy = policy;
  for (size_t m = 0; m < total; ++m) c.mono_channel[m] = 0;  // mono: every motor in unison on channel 1
  return c;
}

LiveSession::LiveSession(std::vector<LiveBoard> boards, const AllocatorConfig &config, int refresh_ms)
    : allocator_(config), refresh_ms_(refresh_ms) {
  for (LiveBoard lb : boards) {
    if (lb.motors.empty())
      for (uint8_t m = 0; m < lb.motor_count; ++m) lb.motors.push_back(m);
    if (!lb.link || lb.motor_count == 0 || lb.motor_count > sc::kMaxMotors || lb.motors.size() != lb.motor_count)
      throw std::invalid_argument("live: a board without a link or with an unusable motor count");
    for (uint8_t m : lb.motors)
      if (m >= sc::kMaxMotors) throw std::invalid_argument("live: a board motor index out of range");
    auto b = std::make_unique<BoardThreads>();
    b->board = lb;
    b->link.store(lb.link);
    b->first_motor = motor_count_;
    for (size_t m = 0; m < lb.motor_count && motor_count_ + m < Allocator::kMaxMotors; ++m)
      board_of_[motor_count_ + m] = static_cast<uint8_t>(boards_.size());
    motor_count_ += lb.motor_count;
    boards_.push_back(std::move(b));
  }
  if (motor_count_ != config.motor_count)
    throw std::invalid_argument("live: the allocator has " + std::to_string(config.motor_count) +
                                " motors, the boards " + std::to_string(motor_count_));
  for (auto &n : notes_) n.store(-1);
}

LiveSession::~LiveSession() { stop(); }

void LiveSession::start() {
  if (started_) return;
  started_ = true;
  for (auto &b : boards_) {
    uint8_t wd[3] = {sc::kMsgWatchdog, 0, 0};
    sc::put_u16(&wd[1], sc::kWatchdogDefaultMs);  // the motors stop by themselves if this program dies
    write_payload(*b->link.load(), *b->stats, wd, sizeof wd);
  }
  for (auto &b : boards_) {
    BoardThreads *p = b.get();
    p->reader = std::thread([this, p] { reader_loop(*p); });
    p->writer = std::thread([this, p] { writer_loop(*p); });
  }
  engine_ = std::thread([this] { engine_loop(); });
}

void LiveSession::stop() {
  if (!started_ || stopped_) return;
  stopped_ = true;
  stop_engine_.store(true);
  engine_.join();  // its last act: a silent entry for every motor
  for (auto &b : boards_) b->stop_writer.store(true);
  for (auto &b : boards_) b->writer.join();  // each drains its queue, then sends stop-all
  for (auto &b : boards_) b->stop_reader.store(true);
  for (auto &b : boards_) b->reader.join();
}

bool LiveSession::detach_link(size_t board, int timeout_ms) {
  BoardThreads &b = *boards_.at(board);
  const uint32_t gen = b.detach_gen.load() + 1;
  b.detach_gen.store(gen, std::memory_order_release);
  const auto end = Clock::now() + std::chrono::milliseconds(timeout_ms);
  while (b.writer_parked_gen.load(std::memory_order_acquire) != gen ||
         b.reader_parked_gen.load(std::memory_order_acquire) != gen) {
    if (Clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

void LiveSession::attach_link(size_t board, Link *link) {
  BoardThreads &b = *boards_.at(board);
  b.link.store(link, std::memory_order_release);
  b.board.link = link;
  b.stats->write_failed.store(false);
  b.stats->read_failed.store(false);
  b.stats->last_status_us.store(0);
  b.attach_gen.store(b.detach_gen.load(), std::memory_order_release);
}

int LiveSession::motor_note(size_t m) const noexcept {
  return m < notes_.size() ? notes_[m].load(std::memory_order_relaxed) : -1;
}

// The engine thread: MIDI events -> allocator -> per-board updates; on stop, silence.
// Per event: Allocator::handle (table walks and one exp2 per retuned motor, a few us) and
// one try_enqueue per changed motor. Never allocates, locks or logs.
void LiveSession::engine_loop() {
  realtime_.fetch_add(make_realtime(kEnginePriority) ? 1 : 0);
  sc::PeriodEntry out[Allocator::kMaxMotors];
  MidiEvent ev;
  while (!stop_engine_.load(std::memory_order_acquire)) {
    if (!midi_queue_.wait_dequeue_timed(ev, std::chrono::milliseconds(20))) continue;
    do {
      const size_t n = allocator_.handle(ev, out, Allocator::kMaxMotors);
      const uint64_t now = monotonic_us();
      engine_latency_->record(now > ev.timestamp_us ? now - ev.timestamp_us : 0);
      route(out, n, ev.timestamp_us);
      events_.fetch_add(1, std::memory_order_relaxed);
    } while (!stop_engine_.load(std::memory_order_relaxed) && midi_queue_.try_dequeue(ev));
  }
  const size_t n = allocator_.panic(out, Allocator::kMaxMotors);
  route(out, n, monotonic_us());
}

// Called from: the engine thread. Writes each entry itself when its board's link is idle
// (try_write_now), else hands it to the board's writer; publishes the motor's note. Waits
// (yielding) only when a writer's queue is full, which a stuck link causes.
void LiveSession::route(const sc::PeriodEntry *entries, size_t n, uint64_t event_us) {
  for (size_t i = 0; i < n; ++i) {
    const size_t m = entries[i].motor;
    BoardThreads &b = *boards_[board_of_[m]];
    const MotorUpdate u{b.board.motors[m - b.first_motor], entries[i].period_q8, event_us};
    if (!try_write_now(b, u)) {
      while (!b.updates.try_enqueue(u)) std::this_thread::yield();
      ++b.enqueued;
    }
    const MotorState s = allocator_.motor(m);
    notes_[m].store(s.sounding && s.period_q8 ? s.played_note : -1, std::memory_order_relaxed);
  }
}

// Called from: the engine thread (route). Writes u's frame at once when board b's link is
// idle: the engine got link_owned, the writer has taken every update queued before (so u
// cannot overtake one), nothing waits in the coalescer, the link is attached, the budget has
// room and the OS takes the frame without waiting (Link::try_write). Budget: one Coalescer
// copy and add, one frame encoded, one non-blocking write() (a few us on a pty). Never waits;
// does not allocate or log. False: nothing was written, the caller queues u for the writer.
bool LiveSession::try_write_now(BoardThreads &b, const MotorUpdate &u) {
  if (b.link_owned.exchange(true, std::memory_order_acquire)) return false;
  bool done = false;
  BoardStats &stats = *b.stats;
  if (b.absorbed.load(std::memory_order_acquire) == b.enqueued && !b.coalescer.pending() &&
      b.detach_gen.load(std::memory_order_acquire) == b.attach_gen.load(std::memory_order_acquire) &&
      !stats.write_failed.load(std::memory_order_relaxed)) {
    b.budget.refill(monotonic_us());
    Coalescer next = b.coalescer;  // taken over only once the frame is written
    next.add(u);
    sc::PeriodEntry e[Coalescer::kMaxMotors];
    uint64_t event_us[Coalescer::kMaxMotors];
    const size_t silences = next.take_silences(e, event_us);  // none: the coalescer was idle
    const size_t n = silences ? 0 : next.take_latest(e, event_us);
    uint8_t payload[sc::kSetPeriodBytes], wire[sc::kMaxFrameWire];
    if (silences == 0 && n == 0) {  // nothing to send (a silence to a silent motor)
      b.coalescer = next;
      done = true;
    } else if (silences == 0 && n == 1 && b.budget.can_send()) {
      sc::put_entry(payload, e[0].motor, e[0].period_q8);
      const uint8_t len = sc::encode_frame(payload, sizeof payload, wire);
      if (b.link.load(std::memory_order_acquire)->try_write(wire, len)) {
        const uint64_t now = monotonic_us();
        if (event_us[0] != 0) latency_->record(now > event_us[0] ? now - event_us[0] : 0);
        b.coalescer = next;
        stats.frames_sent.fetch_add(1, std::memory_order_relaxed);
        stats.bytes_sent.fetch_add(len, std::memory_order_relaxed);
        stats.entries_sent.fetch_add(1, std::memory_order_relaxed);
        stats.direct_frames.fetch_add(1, std::memory_order_relaxed);
        b.budget.spend(len);
        b.sent_bytes += len;
        done = true;
      }
    }
  }
  b.link_owned.store(false, std::memory_order_release);
  return done;
}

// Called from: the writer thread, holding board b's link_owned.
// Writes the coalescer's pending silences, then its latest states, and charges every byte
// written on the link since the last call to the budget. Does not allocate; blocks in write().
void LiveSession::send_pending(BoardThreads &b, Link &link) {
  BoardStats &stats = *b.stats;
  sc::PeriodEntry entries[Coalescer::kMaxMotors];
  uint64_t event_us[Coalescer::kMaxMotors];
  size_t n = b.coalescer.take_silences(entries, event_us);
  if (n) write_entries(link, stats, *latency_, entries, event_us, n);
  n = b.coalescer.take_latest(entries, event_us);
  if (n) write_entries(link, stats, *latency_, entries, event_us, n);
  stats.coalesced.store(b.coalescer.coalesced(), std::memory_order_relaxed);
  const uint64_t total = stats.bytes_sent.load(std::memory_order_relaxed);
  b.budget.spend(total - b.sent_bytes);
  b.sent_bytes = total;
}

// One board's writer thread: coalesced set-period frames, heartbeats, status requests; at the
// end stop-all. Budget per wake: drain the queue (tens of ns an update), encode at most two
// frames (< 1 us), then Link::write (a syscall; blocks while the OS buffer is full).
void LiveSession::writer_loop(BoardThreads &b) {
  realtime_.fetch_add(make_realtime(kWriterPriority) ? 1 : 0);
  BoardStats &stats = *b.stats;
  Coalescer &coalescer = b.coalescer;
  LinkBudget &budget = b.budget;
  auto last_write = Clock::now(), last_status = Clock::now(), last_refresh = Clock::now();
  bool parked = false;
  for (;;) {
    const bool stopping = b.stop_writer.load(std::memory_order_acquire);
    // Sleep until an update comes, or until the budget allows what is pending, or 10 ms.
    uint64_t wait_us;
    {
      LinkOwnership own(b.link_owned);
      budget.refill(monotonic_us());
      wait_us = stopping                ? 0
                : coalescer.pending()   ? std::max<uint64_t>(budget.wait_us(), 1)
                : b.song.peek()         ? 500  // song frames wait for budget to spare
                                        : 10000;
    }
    MotorUpdate u;
    const bool woke = b.updates.wait_dequeue_timed(u, std::chrono::microseconds(wait_us));
    LinkOwnership own(b.link_owned);
    if (woke) {
      uint64_t taken = 1;
      coalescer.add(u);
      while (b.updates.try_dequeue(u)) {
        coalescer.add(u);
        ++taken;
      }
      b.absorbed.fetch_add(taken, std::memory_order_release);
    } else if (stopping && !coalescer.pending()) {
      break;
    }
    const uint32_t detached = b.detach_gen.load(std::memory_order_acquire);
    if (detached != b.attach_gen.load(std::memory_order_acquire)) {  // no link: collect only
      b.writer_parked_gen.store(detached, std::memory_order_release);
      parked = true;
      if (stopping) break;
      continue;
    }
    Link &link = *b.link.load(std::memory_order_acquire);
    if (parked) {  // a new board: it starts silent, with its watchdog at the default
      parked = false;
      uint8_t wd[3] = {sc::kMsgWatchdog, 0, 0};
      sc::put_u16(&wd[1], sc::kWatchdogDefaultMs);
      write_payload(link, stats, wd, sizeof wd);
      coalescer.board_restarted();
    }
    if (Clock::now() - last_refresh >= std::chrono::milliseconds(refresh_ms_)) {
      coalescer.refresh(b.board.motors.data(), b.board.motors.size());
      last_refresh = Clock::now();
    }
    budget.refill(monotonic_us());
    if (coalescer.pending() && (budget.can_send() || stopping)) {
      send_pending(b, link);
      last_write = Clock::now();
    }
    // Song frames (jam) go when no live update waits, within the budget and leaving it half
    // a burst to spare, so that a live note finds room at once.
    budget.refill(monotonic_us());
    for (WireFrame *f = b.song.peek(); f && !coalescer.pending() && song_room(budget, f->len); f = b.song.peek()) {
      bool ok = false;
      try {
        ok = link.write(f->bytes, f->len);
      } catch (...) {
      }
      if (!ok) {
        stats.write_failed.store(true, std::memory_order_relaxed);
        break;
      }
      stats.frames_sent.fetch_add(1, std::memory_order_relaxed);
      stats.bytes_sent.fetch_add(f->len, std::memory_order_relaxed);
      budget.spend(f->len);
      b.sent_bytes += f->len;
      b.song.pop();
      last_write = Clock::now();
    }
    const auto now = Clock::now();
    if (now - last_write >= std::chrono::milliseconds(kHeartbeatMs)) {
      const uint8_t hb = sc::kMsgHeartbeat;
      if (write_payload(link, stats, &hb, 1)) stats.heartbeats.fetch_add(1, std::memory_order_relaxed);
      last_write = now;
    }
    if (now - last_status >= std::chrono::milliseconds(kStatusEveryMs)) {
      const uint8_t req = sc::kMsgStatusReq;
      write_payload(link, stats, &req, 1);
      last_status = now;
    }
    const uint64_t total = stats.bytes_sent.load(std::memory_order_relaxed);
    budget.spend(total - b.sent_bytes);  // every byte on the line counts, heartbeats too
    b.sent_bytes = total;
  }
  // Every motor got its silent entry from the engine's panic; stop-all also empties the board's
  // queue and turns the drivers off.
  LinkOwnership own(b.link_owned);
  if (b.detach_gen.load() == b.attach_gen.load()) {
    const uint8_t stop_all = sc::kMsgStopAll;
    write_payload(*b.link.load(), stats, &stop_all, 1);
  }
}

bool LiveSession::send_song_frame(size_t board, const uint8_t *wire, size_t n) {
  if (n == 0 || n > sc::kMaxFrameWire) return false;
  WireFrame f;
  f.len = static_cast<uint8_t>(n);
  std::copy(wire, wire + n, f.bytes);
  return boards_.at(board)->song.try_enqueue(f);
}

long LiveSession::read_board_bytes(size_t board, uint8_t *out, size_t len, int timeout_ms) {
  BoardThreads &b = *boards_.at(board);
  if (b.partial_pos >= b.partial.len) {
    if (!b.replies.wait_dequeue_timed(b.partial, std::chrono::milliseconds(timeout_ms))) return 0;
    b.partial_pos = 0;
  }
  const size_t n = std::min<size_t>(len, b.partial.len - b.partial_pos);
  std::copy(b.partial.bytes + b.partial_pos, b.partial.bytes + b.partial_pos + n, out);
  b.partial_pos += n;
  return static_cast<long>(n);
}

// One board's reader thread: replies -> BoardStats. Not on the real-time path.
void LiveSession::reader_loop(BoardThreads &b) {
  sc::FrameDecoder decoder;
  uint8_t buf[256];
  BoardStats &stats = *b.stats;
  while (!b.stop_reader.load(std::memory_order_acquire)) {
    const uint32_t detached = b.detach_gen.load(std::memory_order_acquire);
    if (detached != b.attach_gen.load(std::memory_order_acquire)) {
      b.reader_parked_gen.store(detached, std::memory_order_release);
      decoder = sc::FrameDecoder();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    long n = -1;
    try {
      n = b.link.load(std::memory_order_acquire)->read(buf, sizeof buf, 50);
    } catch (...) {
    }
    if (n < 0) {
      stats.read_failed.store(true, std::memory_order_relaxed);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    for (long i = 0; b.forward && i < n; i += sizeof(ReplyChunk::bytes)) {
      ReplyChunk c;
      c.len = static_cast<uint8_t>(std::min<long>(n - i, sizeof c.bytes));
      std::copy(buf + i, buf + i + c.len, c.bytes);
      b.replies.try_enqueue(c);  // a player that stopped reading loses bytes, never blocks this
    }
    for (long i = 0; i < n; ++i) {
      if (decoder.push(buf[i]) != sc::kFrameOk) continue;
      const uint8_t *p = decoder.payload();
      const uint8_t len = decoder.payload_len();
      if (p[0] == sc::kMsgError && len >= 4) {
        stats.board_errors.fetch_add(1, std::memory_order_relaxed);
        stats.last_error.store(p[1], std::memory_order_relaxed);
      } else if (p[0] == sc::kMsgStatus) {
        try {
          const Status s = parse_status(p, len);
          stats.status_frames_bad.store(s.head.frames_bad, std::memory_order_relaxed);
          stats.status_overruns.store(s.head.uart_overruns, std::memory_order_relaxed);
          stats.watchdog_tripped.store(s.head.flags & sc::kStatusWatchdogTripped, std::memory_order_relaxed);
          uint8_t sounding = 0;
          for (size_t m = 0; m < s.motors.size() && m < 8; ++m)
            if (s.motors[m].flags & sc::kMotorSounding) sounding = static_cast<uint8_t>(sounding | (1u << m));
          stats.sounding_mask.store(sounding, std::memory_order_relaxed);
          stats.last_status_us.store(monotonic_us(), std::memory_order_relaxed);
        } catch (const std::exception &) {
        }
      }
    }
  }
}

}  // namespace stepchoir

// session.cpp: the live session: the pool of boards, the engine thread, start and stop.
#include "live/session.h"

#include <pthread.h>
#include <sched.h>

#include <chrono>
#include <stdexcept>
#include <string>

#include "live/rt_guard.h"

namespace stepchoir {

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
    : allocator_(config) {
  for (LiveBoard lb : boards) {
    if (lb.motors.empty())
      for (uint8_t m = 0; m < lb.motor_count; ++m) lb.motors.push_back(m);
    // (A board with no motor of the pool carries a jam's song alone.)
    if (!lb.link || lb.motor_count > sc::kMaxMotors || lb.motors.size() != lb.motor_count)
      throw std::invalid_argument("live: a board without a link or with an unusable motor count");
    for (uint8_t m : lb.motors)
      if (m >= sc::kMaxMotors) throw std::invalid_argument("live: a board motor index out of range");
    for (size_t m = 0; m < lb.motor_count && motor_count_ + m < Allocator::kMaxMotors; ++m) {
      board_of_[motor_count_ + m] = static_cast<uint8_t>(boards_.size());
      board_motor_[motor_count_ + m] = lb.motors[m];
    }
    motor_count_ += lb.motor_count;
    boards_.push_back(std::make_unique<BoardLink>(lb, *latency_, realtime_, refresh_ms));
  }
  if (motor_count_ != config.motor_count)
    throw std::invalid_argument("live: the allocator has " + std::to_string(config.motor_count) +
                                " motors, the boards " + std::to_string(motor_count_));
  for (auto &n : notes_) n.store(-1);
}

LiveSession::~LiveSession() { stop(); }

void LiveSession::set_presets(std::vector<LivePreset> presets) {
  if (started_) throw std::logic_error("live: presets are set before the session starts");
  for (const LivePreset &p : presets) {
    if (const char *why = Allocator::validate(p.config))
      throw std::invalid_argument("preset '" + p.name + "': " + why);
    if (p.config.motor_count != motor_count_)
      throw std::invalid_argument("preset '" + p.name + "' has " + std::to_string(p.config.motor_count) +
                                  " motors, the boards " + std::to_string(motor_count_));
  }
  presets_ = std::move(presets);
  if (!presets_.empty()) allocator_.configure(presets_[0].config);
  preset_.store(presets_.empty() ? -1 : 0);
}

void LiveSession::start() {
  if (started_) return;
  started_ = true;
  for (auto &b : boards_) b->start();
  engine_ = std::thread([this] { engine_loop(); });
}

void LiveSession::stop() {
  if (!started_ || stopped_) return;
  stopped_ = true;
  stop_engine_.store(true);
  engine_.join();  // its last act: a silent entry for every motor
  for (auto &b : boards_) b->request_stop_writer();  // each drains its queue, then sends stop-all
  for (auto &b : boards_) b->join_writer();  // all asked first: one stuck link holds no other up
  for (auto &b : boards_) b->request_stop_reader();
  for (auto &b : boards_) b->join_reader();
}

bool LiveSession::detach_link(size_t board, int timeout_ms) { return boards_.at(board)->detach(timeout_ms); }

void LiveSession::attach_link(size_t board, Link *link) { boards_.at(board)->attach(link); }

bool LiveSession::send_song_frame(size_t b, const uint8_t *wire, size_t n) { return boards_.at(b)->queue_song_frame(wire, n); }

long LiveSession::read_board_bytes(size_t b, uint8_t *out, size_t len, int timeout_ms) {
  return boards_.at(b)->read_replies(out, len, timeout_ms);
}

int LiveSession::motor_note(size_t m) const noexcept {
  return m < notes_.size() ? notes_[m].load(std::memory_order_relaxed) : -1;
}

// The engine thread: MIDI events -> allocator -> boards; on stop, silence. Per event:
// Allocator::handle (table walks and one exp2 per retuned motor, a few us) and one
// BoardLink::post per changed motor; while a motor vibrates, every kVibratoTickUs an
// Allocator::tick (one sine and one exp2 per vibrating motor) and a post per motor whose
// period moved. Never allocates, locks or logs (RtScope).
void LiveSession::engine_loop() {
  sched_param p{};
  p.sched_priority = kEnginePriority;
  realtime_.fetch_add(pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0 ? 1 : 0);
  sc::PeriodEntry out[Allocator::kMaxMotors];
  MidiEvent ev;
  uint64_t next_tick_us = 0;
  while (!stop_engine_.load(std::memory_order_acquire)) {
    const bool vibrating = allocator_.vibrating();
    const uint64_t start = monotonic_us();
    const uint64_t wait_us = !vibrating ? 20000 : next_tick_us > start ? next_tick_us - start : 0;
    if (midi_queue_.wait_dequeue_timed(ev, std::chrono::microseconds(wait_us))) {
      RtScope rt;
      do {
        const size_t n = apply(ev, out);
        const uint64_t now = monotonic_us();
        engine_latency_->record(now > ev.timestamp_us ? now - ev.timestamp_us : 0);
        route(out, n, ev.timestamp_us);
        events_.fetch_add(1, std::memory_order_relaxed);
      } while (!stop_engine_.load(std::memory_order_relaxed) && midi_queue_.try_dequeue(ev));
    }
    const uint64_t now = monotonic_us();
    if (allocator_.vibrating() && now >= next_tick_us) {  // the vibrato and glides move on
      RtScope rt;
      // event time 0: no key caused these updates, so they stay out of the latency figures
      route(out, allocator_.tick(now, out, Allocator::kMaxMotors), 0);
      next_tick_us = now + kVibratoTickUs;
    }
  }
  RtScope rt;
  const size_t n = allocator_.panic(out, Allocator::kMaxMotors);
  route(out, n, monotonic_us());
}

// Called from: the engine thread, for each MIDI event. A program change that selects a preset
// reconfigures the allocator (a copy of about 2 KB, no allocation) and returns a silent entry for
// every motor that sounded: the switch takes effect in this engine cycle. With presets, every
// other program change is dropped (no drum kit switching); all else goes to Allocator::handle.
// Writes at most Allocator::kMaxMotors entries to out; returns the count.
size_t LiveSession::apply(const MidiEvent &ev, sc::PeriodEntry *out) {
  if (presets_.empty()) return allocator_.handle(ev, out, Allocator::kMaxMotors);
  const int chosen = selector_.select(ev, presets_.data(), presets_.size());
  if (chosen >= 0) {
    allocator_.configure(presets_[static_cast<size_t>(chosen)].config);  // validated by set_presets
    preset_.store(chosen, std::memory_order_relaxed);
    return allocator_.flush(out, Allocator::kMaxMotors);
  }
  if ((ev.status & 0xF0) == kMidiProgramChange) return 0;
  return allocator_.handle(ev, out, Allocator::kMaxMotors);
}

// Called from: the engine thread. Posts each entry to its board and publishes the motor's note.
// event_us: the MIDI event's time, or 0 for updates no key caused (kept out of the latency).
void LiveSession::route(const sc::PeriodEntry *entries, size_t n, uint64_t event_us) {
  for (size_t i = 0; i < n; ++i) {
    const size_t m = entries[i].motor;
    boards_[board_of_[m]]->post(MotorUpdate{board_motor_[m], entries[i].period_q8, event_us});
    const MotorState s = allocator_.motor(m);
    notes_[m].store(s.sounding && s.period_q8 ? s.played_note : -1, std::memory_order_relaxed);
  }
}

}  // namespace stepchoir

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

bool LiveSession::queue_stage(const StageCommand &c) {
  if (!stage_queue_.try_enqueue(c)) return false;
  ++stage_sent_;
  return true;
}

bool LiveSession::perform(const StageAction &a) { return queue_stage({StageCommand::Kind::kAction, a, {}, 0, 0}); }

bool LiveSession::select_preset(size_t index) { return queue_stage({StageCommand::Kind::kPreset, {}, {}, index, 0}); }

bool LiveSession::bind(const Binding &b) { return queue_stage({StageCommand::Kind::kBind, {}, b, 0, 0}); }

bool LiveSession::learn(Action a, uint8_t motor) {
  learned_.store(0, std::memory_order_relaxed);
  return queue_stage({StageCommand::Kind::kLearn, StageAction{a, 127, motor}, {}, 0, 0});
}

bool LiveSession::set_song_pool(uint32_t motors) { return queue_stage({StageCommand::Kind::kSongPool, {}, {}, 0, motors}); }

std::optional<Binding> LiveSession::learned() {
  const uint64_t v = learned_.exchange(0, std::memory_order_acquire);
  if (!(v & kLearnedValid)) return std::nullopt;
  return Binding{static_cast<int8_t>(int(v >> 24 & 0xFF) - 1), static_cast<uint8_t>(v >> 16 & 0xFF),
                 static_cast<Action>(v >> 8 & 0xFF), static_cast<uint8_t>(v & 0xFF)};
}

uint32_t LiveSession::motor_period_q8(size_t m) const noexcept {
  return m < periods_.size() ? periods_[m].load(std::memory_order_relaxed) : 0;
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
    const uint64_t wait_us = !vibrating ? kIdleWaitUs : next_tick_us > start ? next_tick_us - start : 0;
    const bool got = midi_queue_.wait_dequeue_timed(ev, std::chrono::microseconds(wait_us));
    // The stage's commands first: one queued before a MIDI event arrived applies before it.
    StageCommand command;
    while (stage_queue_.try_dequeue(command)) {
      RtScope rt;
      route(out, stage(command, out), 0);  // no key caused these: they stay out of the latency
      stage_done_.fetch_add(1, std::memory_order_release);
    }
    if (got) {
      RtScope rt;
      do {
        const size_t n = apply(ev, out);
        const uint64_t now = monotonic_us();
        engine_latency_->record(now > ev.timestamp_us ? now - ev.timestamp_us : 0);
        route(out, n, ev.timestamp_us);
        recent_.record(ev);
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

// Called from: the engine thread, for each MIDI event. While a learn() waits, the first control
// change 0-119 with a value above 0 (a press or a knob's move, not a pedal's release) becomes its
// binding and goes no further. A control change a binding claims is its
// action's alone (act()). A program change that selects a preset reconfigures the allocator (a copy of about 2 KB, no allocation) and returns a silent entry for
// every motor that sounded: the switch takes effect in this engine cycle. With presets, every
// other program change is dropped (no drum kit switching); all else goes to Allocator::handle.
// Writes at most Allocator::kMaxMotors entries to out; returns the count.
size_t LiveSession::apply(const MidiEvent &ev, sc::PeriodEntry *out) {
  const bool controller = (ev.status & 0xF0) == kMidiControlChange && ev.data1 < kCcAllSoundOff;
  if (learning_ && controller && ev.data2 > 0) {
    const Binding b{static_cast<int8_t>(ev.status & 0x0F), ev.data1, learning_->action, learning_->motor};
    learning_.reset();
    if (controls_.bind(b))
      learned_.store(kLearnedValid | uint64_t(b.channel + 1) << 24 | uint64_t(b.cc) << 16 |
                         uint64_t(static_cast<uint8_t>(b.action)) << 8 | b.motor,
                     std::memory_order_release);
    return 0;
  }
  StageAction action;
  bool fire = false;
  if (controller && controls_.claim(ev, &action, &fire)) return fire ? act(action, out) : 0;
  if (presets_.empty()) return allocator_.handle(ev, out, Allocator::kMaxMotors);
  const int chosen = selector_.select(ev, presets_.data(), presets_.size());
  if (chosen >= 0) return switch_preset(static_cast<size_t>(chosen), out);
  if ((ev.status & 0xF0) == kMidiProgramChange) return 0;
  return allocator_.handle(ev, out, Allocator::kMaxMotors);
}

// Called from: the engine thread. Makes preset `index` active (validated by set_presets) and
// returns a silent entry for every motor that sounded.
size_t LiveSession::switch_preset(size_t index, sc::PeriodEntry *out) {
  if (index >= presets_.size()) return 0;
  allocator_.configure(presets_[index].config);
  preset_.store(static_cast<int>(index), std::memory_order_relaxed);
  return allocator_.flush(out, Allocator::kMaxMotors);
}

// Called from: the engine thread, for each command of the stage queue.
size_t LiveSession::stage(const StageCommand &c, sc::PeriodEntry *out) {
  switch (c.kind) {
    case StageCommand::Kind::kAction: return act(c.action, out);
    case StageCommand::Kind::kPreset: return switch_preset(c.preset, out);
    case StageCommand::Kind::kBind: controls_.bind(c.binding); return 0;
    case StageCommand::Kind::kLearn: learning_ = c.action; return 0;
    case StageCommand::Kind::kSongPool:
      song_pool_ = c.motors;
      allocator_.set_stage_mutes(stage_mutes_.load(std::memory_order_relaxed) | song_pool_);
      return allocator_.flush(out, Allocator::kMaxMotors);
  }
  return 0;
}

// Called from: the engine thread: a stage action (a learned controller's or the main thread's).
// Writes at most Allocator::kMaxMotors entries to out; returns the count.
size_t LiveSession::act(const StageAction &a, sc::PeriodEntry *out) {
  const int steps[] = {1, -1, 12, -12};
  switch (a.action) {
    case Action::kTransposeUp:
    case Action::kTransposeDown:
    case Action::kOctaveUp:
    case Action::kOctaveDown:
      allocator_.set_stage_transpose(allocator_.stage_transpose() + steps[static_cast<int>(a.action)]);
      stage_transpose_.store(allocator_.stage_transpose(), std::memory_order_relaxed);
      return 0;
    case Action::kGlideTime:
      allocator_.control_all(kCcPortamentoTime, a.value);
      allocator_.control_all(kCcPortamento, a.value > 0 ? 127 : 0);
      break;
    case Action::kVibratoDepth: allocator_.control_all(kCcModWheel, a.value); break;
    case Action::kVibratoRate: allocator_.set_vibrato_rate(vibrato_rate_hz(a.value)); return 0;
    case Action::kPresetNext:
    case Action::kPresetPrevious: {
      if (presets_.empty()) return 0;
      const size_t n = presets_.size(), now = static_cast<size_t>(preset_.load(std::memory_order_relaxed));
      return switch_preset(a.action == Action::kPresetNext ? (now + 1) % n : (now + n - 1) % n, out);
    }
    case Action::kSetlistNext: setlist_steps_.fetch_add(1, std::memory_order_relaxed); return 0;
    case Action::kSetlistPrevious: setlist_steps_.fetch_sub(1, std::memory_order_relaxed); return 0;
    case Action::kPanic:
      panics_.fetch_add(1, std::memory_order_relaxed);
      return allocator_.panic(out, Allocator::kMaxMotors);
    case Action::kMuteMotor:
      if (a.motor >= motor_count_) return 0;
      stage_mutes_.store(stage_mutes_.load(std::memory_order_relaxed) ^ (1u << a.motor), std::memory_order_relaxed);
      allocator_.set_stage_mutes(stage_mutes_.load(std::memory_order_relaxed) | song_pool_);
      break;
  }
  return allocator_.flush(out, Allocator::kMaxMotors);
}

// Called from: the engine thread. Posts each entry to its board and publishes the motor's note.
// event_us: the MIDI event's time, or 0 for updates no key caused (kept out of the latency).
void LiveSession::route(const sc::PeriodEntry *entries, size_t n, uint64_t event_us) {
  for (size_t i = 0; i < n; ++i) {
    const size_t m = entries[i].motor;
    boards_[board_of_[m]]->post(MotorUpdate{board_motor_[m], entries[i].period_q8, event_us});
    const MotorState s = allocator_.motor(m);
    notes_[m].store(s.sounding && s.period_q8 ? s.played_note : -1, std::memory_order_relaxed);
    periods_[m].store(entries[i].period_q8, std::memory_order_relaxed);
  }
}

}  // namespace stepchoir

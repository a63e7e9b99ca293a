// session.h: the live path after the MIDI callback: the engine thread and one BoardLink (writer
// and reader threads) per board.
//
// Threads and their budgets (docs/ARCHITECTURE.md, "Live path"):
//   MIDI callback (midi_in.h) -- MidiQueue --> engine thread: Allocator::handle and pitch math,
//     a few microseconds an event; posts each changed motor to its board (BoardLink::post),
//     which writes the frame itself when that board's link is idle, else queues it for the
//     board's writer thread (board_link.h: the threads' contract).
//   writer thread (one per board): coalesced set-period frames within the link budget,
//     heartbeats, status requests, state refreshes, jam song frames.
//   reader thread (one per board): decodes replies (errors, status) for the link health.
// Stage actions (live/stage.h): the main thread's commands (console keys, the learn prompt, the
// setlist) reach the engine through a second single-producer queue; learned controllers are
// claimed by the engine before the allocator sees them.
// Presets (live/presets.h): the engine holds every preset's AllocatorConfig, built before start();
// a program change that selects one reconfigures the allocator and sends the silences within
// the same engine cycle.
// The engine and writer threads never allocate, lock or log after start() (RtScope: debug
// builds abort if they allocate); the writer blocks only in Link::write, the engine only to
// finish a rare partial write.
// Everything is counted in atomics that the main thread reads and logs.
#ifndef STEPCHOIR_HOST_LIVE_SESSION_H
#define STEPCHOIR_HOST_LIVE_SESSION_H

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "board/link.h"
#include "live/allocator.h"
#include "live/board_link.h"
#include "live/coalescer.h"
#include "live/event_log.h"
#include "live/latency_histogram.h"
#include "live/link_budget.h"
#include "live/midi_in.h"
#include "live/presets.h"
#include "live/stage.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

// Defaults for a pool: every motor plays the piano range on its board's clock.
// Called from: setup code. Throws std::invalid_argument when the pool has no motor or more
// than Allocator::kMaxMotors.
AllocatorConfig pool_config(const std::vector<LiveBoard> &boards, Policy policy);

class LiveSession {
 public:
  static constexpr size_t kMidiQueueEvents = 4096;
  // SCHED_FIFO priority of the engine when the system grants it: below JACK's usual 70-95,
  // above the writers (BoardLink::kWriterPriority).
  static constexpr int kEnginePriority = 60;

  // Builds the queues and the allocator (config.motor_count must be the pool's motor count).
  // Called from: setup code. Allocates; throws std::invalid_argument on a bad configuration.
  // refresh_ms: how often every motor's state is sent again (kRefreshMs; tests that check
  // exact frame sequences turn it down).
  LiveSession(std::vector<LiveBoard> boards, const AllocatorConfig &config, int refresh_ms = kRefreshMs);
  ~LiveSession();  // stop()s
  LiveSession(const LiveSession &) = delete;
  LiveSession &operator=(const LiveSession &) = delete;

  // Hands the engine the presets a program change switches between (live/presets.h); the first
  // becomes active now (the allocator takes its configuration). With none, a program change
  // keeps its General MIDI meaning (a drum kit by bank select); with presets it only switches
  // them. Throws std::invalid_argument naming a preset whose configuration Allocator::validate
  // rejects or whose motor count is not the pool's.
  // Called from: setup code, before start(). Allocates.
  void set_presets(std::vector<LivePreset> presets);
  // The active preset's index in the list set_presets got, -1 when there are none. Called from:
  // any thread (the main thread's status, displays).
  int preset() const noexcept { return preset_.load(std::memory_order_relaxed); }
  // The presets set_presets got; unchanged once start() ran. Called from: any thread.
  const std::vector<LivePreset> &presets() const noexcept { return presets_; }

  // Where the MIDI callback (or a test) puts events. Single producer.
  MidiQueue &midi_queue() { return midi_queue_; }

  // The performer's stage (live/stage.h). Called from: the main thread alone, the stage
  // queue's one producer (console keys, the learn prompt, the setlist); before start() too.
  // The engine applies each command within kIdleWaitUs. Each returns false when the queue is
  // full (kStageCommands wait) and then does nothing. None allocates.
  bool perform(const StageAction &a);
  bool select_preset(size_t index);         // ignored for an index past the presets
  bool bind(const Binding &b);              // a learned controller (the rig file's [[controls]])
  // Binds the next control change 0-119 with a value above 0 (a press, a knob's move; not the
  // release of the control learned before), on any channel, to a.
  bool learn(Action a, uint8_t motor = 0);
  // Live's setlist: bit m, pool motor m plays a song, so the keyboard leaves it (the allocator
  // mutes it besides the performer's mutes); 0 when no song plays.
  bool set_song_pool(uint32_t motors);
  // True once the engine has applied every stage command queued so far. Main thread.
  bool stage_settled() const noexcept { return stage_done_.load(std::memory_order_acquire) == stage_sent_; }
  // The binding the engine made for the latest learn(), once; nothing while it waits.
  std::optional<Binding> learned();
  // Setlist presses (kSetlistNext minus kSetlistPrevious) since the last call. Main thread.
  int take_setlist_steps() noexcept { return setlist_steps_.exchange(0, std::memory_order_relaxed); }
  // The stage's state, for displays. Called from: any thread.
  int stage_transpose() const noexcept { return stage_transpose_.load(std::memory_order_relaxed); }
  uint32_t stage_mutes() const noexcept { return stage_mutes_.load(std::memory_order_relaxed); }
  uint64_t panics() const noexcept { return panics_.load(std::memory_order_relaxed); }

  // Sets every board's watchdog to the protocol default and starts the threads.
  // Called from: the main thread, once.
  void start();

  // Silences every motor (a silent entry for each, then stop-all), waits until the writers
  // handed that to the OS, and joins every thread. Idempotent.
  // Called from: the main thread (Ctrl-C, SIGTERM, a fatal error, the end of a test).
  void stop();

  // Reconnection, for a board whose link failed (BoardStats::write_failed / read_failed).
  // detach_link parks the board's writer and reader (they stop touching the link; the writer
  // keeps collecting the latest state per motor) and waits until they have, up to timeout_ms;
  // false when they did not park in time. attach_link hands them a new link to the same kind
  // of board (the caller owns it and said hello): the writer sets the watchdog, restores every
  // motor that should sound, and carries on.
  // Called from: the main thread.
  bool detach_link(size_t board, int timeout_ms = 3000);
  void attach_link(size_t board, Link *link);
  // True while board b has a link (attached, not detached since). Called from: any thread.
  bool link_attached(size_t b) const { return boards_.at(b)->attached(); }

  // Jam: the song player's side of board b's link. send_song_frame queues one wire frame
  // that the writer sends when no live update waits and the link budget has room to spare
  // (a live note never waits behind song traffic); false when the queue is full.
  // read_board_bytes returns what the board sent since (up to len bytes, waiting up to
  // timeout_ms; 0 on timeout). Only once forward_replies(b) was called (before start()) does
  // the reader keep the bytes for it. Called from: the song player's thread (one per board).
  bool send_song_frame(size_t b, const uint8_t *wire, size_t n);
  long read_board_bytes(size_t b, uint8_t *out, size_t len, int timeout_ms);
  // When board b's writer handed the last song frame queued to the OS (BoardLink), 0 when it
  // did not within timeout_ms. Called from: the song player's thread.
  uint64_t song_frame_written_us(size_t b, int timeout_ms) { return boards_.at(b)->song_frame_written_us(timeout_ms); }
  void forward_replies(size_t b) { boards_.at(b)->forward_replies(); }
  // Live's setlist: bit m, board b's motor m plays a song; the live path leaves it alone
  // (BoardLink::set_song_motors). Called from: the main thread.
  void set_song_motors(size_t b, uint8_t mask) { boards_.at(b)->set_song_motors(mask); }

  // Per pool motor: the MIDI note it plays (played note, after folding), or -1 when silent.
  // Called from: any thread.
  int motor_note(size_t m) const noexcept;
  // Per pool motor: the period it plays now (board timer ticks q8, bend and vibrato included),
  // 0 when silent. Called from: any thread.
  uint32_t motor_period_q8(size_t m) const noexcept;
  // Per pool motor: its board (an index of board_stats) and the board's own number for it.
  // Called from: any thread (displays).
  size_t motor_board(size_t m) const noexcept { return board_of_[m]; }
  uint8_t board_motor(size_t m) const noexcept { return board_motor_[m]; }
  size_t motor_count() const noexcept { return motor_count_; }
  size_t board_count() const noexcept { return boards_.size(); }
  const BoardStats &board_stats(size_t b) const { return boards_[b]->stats(); }
  // MIDI events the engine applied.
  uint64_t events() const noexcept { return events_.load(std::memory_order_relaxed); }
  // The latest of them (the console's "last events"). Called from: any thread.
  const EventLog &recent_events() const noexcept { return recent_; }
  // Threads (engine and writers) that got real-time scheduling; valid once they run.
  int realtime_threads() const noexcept { return realtime_.load(); }
  // MIDI event arrival -> its frame handed to the OS (write() returned), per motor entry.
  const LatencyHistogram &latency() const { return *latency_; }
  // MIDI event arrival -> the engine has applied it (the first hop), per event.
  const LatencyHistogram &engine_latency() const { return *engine_latency_; }

 private:
  // What the main thread asks of the engine (the stage queue's element).
  struct StageCommand {
    enum class Kind : uint8_t { kAction, kPreset, kBind, kLearn, kSongPool } kind = Kind::kAction;
    StageAction action;  // kAction; kLearn: the action and motor to bind
    Binding binding;     // kBind
    size_t preset = 0;   // kPreset
    uint32_t motors = 0; // kSongPool
  };
  static constexpr size_t kStageCommands = 256;
  // How long the engine waits for MIDI before it looks at the stage queue and its stop flag, us.
  static constexpr uint64_t kIdleWaitUs = 5000;

  void engine_loop();                                                       // the engine thread
  size_t stage(const StageCommand &c, sc::PeriodEntry *out);                // engine thread
  size_t act(const StageAction &a, sc::PeriodEntry *out);                   // engine thread
  size_t switch_preset(size_t index, sc::PeriodEntry *out);                 // engine thread
  void route(const sc::PeriodEntry *entries, size_t n, uint64_t event_us);  // engine thread
  size_t apply(const MidiEvent &ev, sc::PeriodEntry *out);                  // engine thread

  std::unique_ptr<LatencyHistogram> latency_ = std::make_unique<LatencyHistogram>();
  std::unique_ptr<LatencyHistogram> engine_latency_ = std::make_unique<LatencyHistogram>();
  std::atomic<int> realtime_{0};
  std::vector<std::unique_ptr<BoardLink>> boards_;
  std::array<uint8_t, Allocator::kMaxMotors> board_of_{};     // pool motor -> board index
  std::array<uint8_t, Allocator::kMaxMotors> board_motor_{};  // pool motor -> the board's own index
  size_t motor_count_ = 0;
  MidiQueue midi_queue_{kMidiQueueEvents};
  Allocator allocator_;
  std::vector<LivePreset> presets_;  // fixed before start(); the engine reads it
  PresetSelector selector_;          // the engine thread's
  std::atomic<int> preset_{-1};
  std::array<std::atomic<int16_t>, Allocator::kMaxMotors> notes_{};
  std::array<std::atomic<uint32_t>, Allocator::kMaxMotors> periods_{};
  moodycamel::ReaderWriterQueue<StageCommand> stage_queue_{kStageCommands};
  ControlMap controls_;                   // the engine thread's
  std::optional<StageAction> learning_;   // the engine thread's: what the next controller binds to
  std::atomic<uint64_t> learned_{0};      // kLearnedValid | channel+1 << 24 | cc << 16 | action << 8 | motor
  static constexpr uint64_t kLearnedValid = uint64_t{1} << 40;
  std::atomic<int> setlist_steps_{0}, stage_transpose_{0};
  std::atomic<uint32_t> stage_mutes_{0};  // the performer's mutes (mute_motor)
  uint32_t song_pool_ = 0;                  // the engine thread's: motors a setlist song plays
  std::atomic<uint64_t> panics_{0};
  std::atomic<uint64_t> stage_done_{0};  // stage commands the engine applied
  uint64_t stage_sent_ = 0;              // stage commands the main thread queued (its own)
  bool queue_stage(const StageCommand &c);  // main thread
  std::atomic<uint64_t> events_{0};
  EventLog recent_;                       // written by the engine thread
  std::atomic<bool> stop_engine_{false};
  std::thread engine_;
  bool started_ = false, stopped_ = false;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_SESSION_H

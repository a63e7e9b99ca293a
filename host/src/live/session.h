// session.h: the live path after the MIDI callback: engine thread, per-board writer and reader
// threads, and the pure pieces they run (Coalescer, LatencyHistogram).
//
// Threads and their budgets (docs/ARCHITECTURE.md, "Live path"):
//   MIDI callback (midi_in.h) -- MidiQueue --> engine thread: Allocator::handle and pitch math,
//     a few microseconds an event; routes each changed motor to its board's UpdateQueue.
//   engine -- UpdateQueue (one per board) --> writer thread: drains every pending update into
//     a Coalescer (latest state per motor; a silence is never dropped), encodes at most two
//     set-period frames and writes them; heartbeats when idle, a status request each second.
//     When that board's link is idle (nothing queued or pending, the budget has room, the
//     writer not in the middle of its work, the OS takes the frame without waiting) the engine
//     writes the frame itself instead (Link::try_write), through the same Coalescer and budget:
//     that saves the writer's wake-up (bench/results/live-latency.md). The board's link_owned
//     flag says who may touch the link, Coalescer and budget: the writer waits for it (the
//     engine holds it for one non-blocking write), the engine only tries it and hands the
//     update to the writer when it is taken.
//   reader thread (one per board): decodes replies (errors, status) for the link health.
// The engine and writer threads never allocate, lock or log after start(); the writer blocks
// only in Link::write, the engine never (it writes only what the OS takes at once). Everything is counted in atomics that the main thread reads and logs.
#ifndef STEPCHOIR_HOST_LIVE_H
#define STEPCHOIR_HOST_LIVE_H

#include <readerwriterqueue/readerwriterqueue.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "board/link.h"
#include "live/allocator.h"
#include "live/midi_in.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

// One motor's new period, engine -> writer. event_us: arrival of the MIDI event behind it.
struct MotorUpdate {
  uint8_t motor;        // the board's own motor index
  uint32_t period_q8;   // ticks q8, 0 = silent
  uint64_t event_us;    // monotonic_us() of the MIDI event
};
using UpdateQueue = moodycamel::BlockingReaderWriterQueue<MotorUpdate>;

// Heartbeat when the writer sent nothing for this long: a quarter of the firmware's watchdog.
constexpr int kHeartbeatMs = sc::kWatchdogDefaultMs / 4;
// Status request (link health) this often.
constexpr int kStatusEveryMs = 1000;
// Pacing: the firmware's main loop cannot take frames as fast as the line carries them, so a
// writer keeps to the protocol's link budget (sc::kLinkBudgetBytesPerSecond in bursts of at
// most sc::kLinkBurstBytes, every byte it writes counted). Measured on the Uno with four motors
// changing note 20,000 times a second (bench/results/live-throughput.md): about 2,000
// set-period entries a second overran the board's UART; 1,200 (the pacing then) did not. A
// player never meets the limit; beyond it the writer coalesces (latest state per motor,
// silences kept).

// Every motor's state is sent again this often, so that a frame the board lost (line noise,
// an overrun) cannot leave a note stuck or missing for longer. Re-sending a sounding motor's
// period keeps its phase; silence to a silent motor does nothing.
constexpr int kRefreshMs = 250;

// The link budget: bytes refilled at sc::kLinkBudgetBytesPerSecond up to sc::kLinkBurstBytes
// (a token bucket). Pure; the writer owns one.
class LinkBudget {
 public:
  static constexpr int64_t kBytesPerSecond = sc::kLinkBudgetBytesPerSecond;
  static constexpr int64_t kBurstBytes = sc::kLinkBurstBytes;
  // Called from: the writer thread, with the monotonic time. Does not allocate.
  void refill(uint64_t now_us) noexcept;
  // True when a frame may go now (the budget may then go negative by that frame's bytes).
  bool can_send() const noexcept { return credit_ >= 0; }
  // Whole bytes of credit now (negative when overspent).
  int64_t credit_bytes() const noexcept { return credit_ / kMicro; }
  void spend(size_t bytes) noexcept { credit_ -= static_cast<int64_t>(bytes) * kMicro; }
  // How long until can_send(), in us (0 when it already can).
  uint64_t wait_us() const noexcept;

 private:
  static constexpr int64_t kMicro = 1000000;  // credit in millionths of a byte, so that
  int64_t credit_ = kBurstBytes * kMicro;     // 1 us adds exactly kBytesPerSecond
  uint64_t last_us_ = 0;
};

// The latest state per motor of one board, while the link is busy. Pure; owned by the writer.
// A motor that went silent and then got a new note before the silence was sent keeps both:
// the silence goes out first (take_silences), then the new note (take_latest), so a repeated
// note is struck again and a silence is never lost. Anything else is coalesced to its latest.
class Coalescer {
 public:
  static constexpr size_t kMaxMotors = sc::kMaxMotors;

  // Called from: the writer thread (and tests). Does not allocate.
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

// Latency samples in 1 us bins up to 20 ms (more is counted as 20 ms). Lock-free: the engine
// and writer threads record, any thread reads (relaxed; figures may trail by a sample).
class LatencyHistogram {
 public:
  static constexpr size_t kBins = 20000;
  // Called from: the engine and writer threads. Does not allocate or block.
  void record(uint64_t us) noexcept;
  // Nearest-rank percentile (q in [0, 1]) in us; 0 with no samples. Called from: any thread.
  uint64_t percentile(double q) const noexcept;
  uint64_t max_us() const noexcept { return max_.load(std::memory_order_relaxed); }
  uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }

 private:
  std::array<std::atomic<uint32_t>, kBins> bins_{};
  std::atomic<uint64_t> count_{0}, max_{0};
};

// What one board's threads did, for the status line and logs. Written by its writer and
// reader threads, read by anyone.
struct BoardStats {
  std::atomic<uint64_t> frames_sent{0}, bytes_sent{0}, entries_sent{0}, heartbeats{0}, coalesced{0};
  std::atomic<uint64_t> direct_frames{0};  // set-period frames the engine wrote itself
  std::atomic<bool> write_failed{false}, read_failed{false};
  std::atomic<uint64_t> board_errors{0};   // kMsgError replies
  std::atomic<uint8_t> last_error{0};      // code of the latest
  std::atomic<uint64_t> last_status_us{0}; // when the latest status reply came (monotonic_us)
  std::atomic<uint32_t> status_frames_bad{0}, status_overruns{0};
  std::atomic<bool> watchdog_tripped{false};
  std::atomic<uint8_t> sounding_mask{0};   // bit m: the board said motor m is sounding
};

// One board of the pool: its link (owned by the caller, alive until stop()) and capabilities.
// motors: the board's motors the live path plays (jam: the others play a song), in pool
// order; empty: 0 .. motor_count-1. motor_count is then motors.size().
struct LiveBoard {
  Link *link = nullptr;
  uint8_t motor_count = 0;
  uint32_t f_cpu_hz = 0;
  std::vector<uint8_t> motors{};
};

// A frame for the board from someone else than the live path (jam: the song player), as
// bytes on the wire.
struct WireFrame {
  uint8_t len = 0;
  uint8_t bytes[sc::kMaxFrameWire];
};
// Bytes the board sent, as its reader thread read them (jam: passed on to the song player).
struct ReplyChunk {
  uint8_t len = 0;
  uint8_t bytes[64];
};

// Defaults for a pool: every motor plays the piano range on its board's clock.
// Called from: setup code. Throws std::invalid_argument when the pool has no motor or more
// than Allocator::kMaxMotors.
AllocatorConfig pool_config(const std::vector<LiveBoard> &boards, Policy policy);

class LiveSession {
 public:
  static constexpr size_t kMidiQueueEvents = 4096;
  static constexpr size_t kUpdateQueueEntries = 4096;
  static constexpr size_t kSongFrames = 64;     // jam: song frames waiting for the link
  static constexpr size_t kReplyChunks = 1024;  // jam: board bytes waiting for the player
  // SCHED_FIFO priorities when the system grants them: below JACK's usual 70-95, the writer
  // under the engine.
  static constexpr int kEnginePriority = 60;
  static constexpr int kWriterPriority = 59;

  // Builds the queues and the allocator (config.motor_count must be the pool's motor count).
  // Called from: setup code. Allocates; throws std::invalid_argument on a bad configuration.
  // refresh_ms: how often every motor's state is sent again (kRefreshMs; tests that check
  // exact frame sequences turn it down).
  LiveSession(std::vector<LiveBoard> boards, const AllocatorConfig &config, int refresh_ms = kRefreshMs);
  ~LiveSession();  // stop()s
  LiveSession(const LiveSession &) = delete;
  LiveSession &operator=(const LiveSession &) = delete;

  // Where the MIDI callback (or a test) puts events. Single producer.
  MidiQueue &midi_queue() { return midi_queue_; }

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

  // Jam: the song player's side of board b's link. send_song_frame queues one wire frame
  // that the writer sends when no live update waits and the link budget has room to spare
  // (a live note never waits behind song traffic); false when the queue is full.
  // read_board_bytes returns what the board sent since (up to len bytes, waiting up to
  // timeout_ms; 0 on timeout). Only once forward_replies(b) was called (before start()) does
  // the reader keep the bytes for it. Called from: the song player's thread (one per board).
  bool send_song_frame(size_t b, const uint8_t *wire, size_t n);
  long read_board_bytes(size_t b, uint8_t *out, size_t len, int timeout_ms);
  void forward_replies(size_t b) { boards_.at(b)->forward = true; }

  // Per pool motor: the MIDI note it plays (played note, after folding), or -1 when silent.
  // Called from: any thread.
  int motor_note(size_t m) const noexcept;
  size_t motor_count() const noexcept { return motor_count_; }
  size_t board_count() const noexcept { return boards_.size(); }
  const BoardStats &board_stats(size_t b) const { return *boards_[b]->stats; }
  // MIDI events the engine applied.
  uint64_t events() const noexcept { return events_.load(std::memory_order_relaxed); }
  // Threads (engine and writers) that got real-time scheduling; valid once they run.
  int realtime_threads() const noexcept { return realtime_.load(); }
  // MIDI event arrival -> its frame handed to the OS (write() returned), per motor entry.
  const LatencyHistogram &latency() const { return *latency_; }
  // MIDI event arrival -> the engine has applied it (the first hop), per event.
  const LatencyHistogram &engine_latency() const { return *engine_latency_; }

 private:
  struct BoardThreads {
    LiveBoard board;         // board.link: only while attached (see link)
    std::atomic<Link *> link{nullptr};
    size_t first_motor = 0;  // pool index of the board's motor 0
    // detach_link bumps detach_gen; each thread, once it no longer touches the link, copies it
    // to its parked_gen; attach_link sets attach_gen = detach_gen.
    std::atomic<uint32_t> detach_gen{0}, attach_gen{0}, writer_parked_gen{0}, reader_parked_gen{0};
    UpdateQueue updates{kUpdateQueueEntries};
    // Who may touch the link, coalescer, budget and sent_bytes (see the top of this file).
    std::atomic<bool> link_owned{false};
    Coalescer coalescer;
    LinkBudget budget;
    uint64_t sent_bytes = 0;         // stats.bytes_sent already charged to the budget
    std::atomic<uint64_t> absorbed{0};  // updates the writer took from `updates` into coalescer
    uint64_t enqueued = 0;           // updates the engine put in `updates` (engine thread only)
    std::unique_ptr<BoardStats> stats = std::make_unique<BoardStats>();
    std::atomic<bool> stop_writer{false}, stop_reader{false};
    std::thread writer, reader;
    // Jam: song frames in, board bytes out (see send_song_frame).
    moodycamel::ReaderWriterQueue<WireFrame> song{kSongFrames};
    moodycamel::BlockingReaderWriterQueue<ReplyChunk> replies{kReplyChunks};
    ReplyChunk partial;      // read_board_bytes: a chunk taken but not all handed out
    size_t partial_pos = 0;
    bool forward = false;
  };

  void engine_loop();                   // the engine thread
  void writer_loop(BoardThreads &b);    // one board's writer thread
  void reader_loop(BoardThreads &b);    // one board's reader thread
  void route(const sc::PeriodEntry *entries, size_t n, uint64_t event_us);  // engine thread
  bool try_write_now(BoardThreads &b, const MotorUpdate &u);               // engine thread
  void send_pending(BoardThreads &b, Link &link);  // writer thread: coalesced entries out

  std::vector<std::unique_ptr<BoardThreads>> boards_;
  std::array<uint8_t, Allocator::kMaxMotors> board_of_{};  // pool motor -> board index
  size_t motor_count_ = 0;
  MidiQueue midi_queue_{kMidiQueueEvents};
  Allocator allocator_;
  std::array<std::atomic<int16_t>, Allocator::kMaxMotors> notes_{};
  std::atomic<uint64_t> events_{0};
  std::unique_ptr<LatencyHistogram> latency_ = std::make_unique<LatencyHistogram>();
  std::unique_ptr<LatencyHistogram> engine_latency_ = std::make_unique<LatencyHistogram>();
  std::atomic<bool> stop_engine_{false};
  std::atomic<int> realtime_{0};
  int refresh_ms_ = kRefreshMs;
  std::thread engine_;
  bool started_ = false, stopped_ = false;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_H

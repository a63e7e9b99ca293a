// board_link.h: one board of a live session: its writer and reader threads, and the one path
// by which a frame reaches the board's link.
//
// Concurrency contract. Who may call what, from which thread:
//   engine thread  post(): writes the update's frame itself when the link is idle (it takes
//                  the ownership below without waiting and makes one non-blocking write,
//                  Link::try_write, which finishes a rare partial write blocking), else
//                  queues the update for the writer. Yields only while the update queue is
//                  full, which only a stuck link causes.
//   writer thread  writer_loop(): takes the ownership (yielding while the engine holds it for
//                  its one write), drains the queue into the coalescer and sends; heartbeats,
//                  status requests, state refreshes, jam song frames; stop-all at the end.
//   reader thread  reader_loop(): decodes replies into the stats; it touches none of the
//                  sending state.
//   song thread    queue_song_frame(), read_replies() (jam, one player a board).
//   main thread    start(), request_stop_*() then join_*() (every board asked before any is
//                  joined), detach(), attach(); stats() from any thread.
// The link's write side, the coalescer and the budget belong to whoever holds the ownership
// flag (owned_); send_wire() checks it is held in debug builds (STEPCHOIR_RT_GUARD). The
// reader reads the link while it is attached; detach() parks both threads before a link goes
// away. Every byte leaves through send_wire(), which writes it, counts it in the stats and
// charges it to the budget, once.
// The engine and writer loops run inside RtScopes: they never allocate, lock or log after
// start() (debug builds abort if they allocate).
#ifndef STEPCHOIR_HOST_LIVE_BOARD_LINK_H
#define STEPCHOIR_HOST_LIVE_BOARD_LINK_H

#include <readerwriterqueue/readerwriterqueue.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <thread>
#include <vector>

#include "board/board.h"
#include "board/link.h"
#include "live/coalescer.h"
#include "live/latency_histogram.h"
#include "live/link_budget.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

using UpdateQueue = moodycamel::BlockingReaderWriterQueue<MotorUpdate>;

// Heartbeat when the writer sent nothing for this long: a quarter of the firmware's watchdog.
constexpr int kHeartbeatMs = sc::kWatchdogDefaultMs / 4;
// Status request (link health) this often.
constexpr int kStatusEveryMs = 1000;
static_assert(Board::kSilentMs >= 3 * kStatusEveryMs, "a silent board has missed three status requests");
// The reader passes at least every 50 ms (its read's timeout); a longer gap is its thread held
// up, not the board's silence (BoardStats::heard_us).
constexpr uint64_t kReaderGapUs = 200000;
// Every motor's state is sent again this often, so that a frame the board lost (line noise,
// an overrun) cannot leave a note stuck or missing for longer. Re-sending a sounding motor's
// period keeps its phase; silence to a silent motor does nothing.
constexpr int kRefreshMs = 250;

// What one board's threads did, for the status line and logs. Written by its engine, writer
// and reader threads (relaxed atomics), read by anyone.
struct BoardStats {
  std::atomic<uint64_t> frames_sent{0}, bytes_sent{0}, entries_sent{0}, heartbeats{0}, coalesced{0};
  std::atomic<uint64_t> direct_frames{0};  // set-period frames the engine wrote itself
  std::atomic<bool> write_failed{false}, read_failed{false};
  // The board announced its capabilities as it started (sc::kCapsAnnounced): it started again
  // with the link up (its reset button, a brown-out) and runs on its defaults, silent. Set by
  // the reader; cleared when a link is attached.
  std::atomic<bool> restarted{false};
  std::atomic<uint64_t> board_errors{0};   // kMsgError replies
  std::atomic<uint8_t> last_error{0};      // code of the latest
  std::atomic<uint64_t> last_status_us{0}; // when the latest status reply came (monotonic_us)
  // When the board last sent a whole frame, or its link started or was attached (monotonic_us),
  // moved on by any time the reader did not listen (its thread held up); and when the reader
  // last read. A board that sends nothing while asked for its status every second has stopped:
  // a Mega reset with its link up stays in its bootloader while bytes keep coming
  // (Board::kSilentMs).
  std::atomic<uint64_t> heard_us{0}, read_us{0};
  std::atomic<uint32_t> status_frames_bad{0}, status_overruns{0};
  std::atomic<bool> watchdog_tripped{false};
  std::atomic<uint8_t> sounding_mask{0};   // bit m: the board said motor m is sounding
  // From the latest status reply too (about once a second, kStatusEveryMs), by the board's own
  // motor index: each carriage's position (steps, 0 .. travel_steps with soft limits), which
  // motors' switches are faulty, each motor's reversals at a switch or a soft limit since the
  // board's counters were reset (power-up, reset-counters), and the board's total of them
  // (all motors). The counts wrap at 65536.
  std::array<std::atomic<int32_t>, sc::kMaxMotors> position_steps{};
  std::atomic<uint8_t> endstop_fault_mask{0};
  std::array<std::atomic<uint16_t>, sc::kMaxMotors> motor_reversals{};
  std::atomic<uint16_t> reversals{0};
  std::atomic<uint32_t> reconnects{0};     // links attach() handed over after a failed one
  // The latest entry a MIDI event caused, handed to the OS: the event's stamp (the MIDI
  // callback's monotonic_us) and when the write() on the link returned (monotonic_us); 0 before
  // the first. Stored one after the other by the link's owner: a pair read once the link has been
  // quiet for a while belongs together (the live bench reads it after each of its single notes).
  std::atomic<uint64_t> last_event_us{0}, last_written_us{0};
};

// One board of the pool: its link (owned by the caller, alive until the session stops) and
// capabilities. motors: the board's motors the live path plays (jam: the others play a song),
// in pool order; empty: 0 .. motor_count-1. motor_count is then motors.size().
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

class BoardLink {
 public:
  static constexpr size_t kUpdateQueueEntries = 4096;
  static constexpr size_t kSongFrames = 64;     // jam: song frames waiting for the link
  static constexpr size_t kReplyChunks = 1024;  // jam: board bytes waiting for the player
  // SCHED_FIFO priority of the writer when the system grants it (below JACK's usual 70-95 and
  // the engine's).
  static constexpr int kWriterPriority = 59;

  // Called from: setup code (LiveSession). board.motors filled in; latency: where entries'
  // MIDI-to-write() latency goes; realtime: counts threads that got SCHED_FIFO.
  BoardLink(const LiveBoard &board, LatencyHistogram &latency, std::atomic<int> &realtime, int refresh_ms);
  BoardLink(const BoardLink &) = delete;
  BoardLink &operator=(const BoardLink &) = delete;

  const LiveBoard &board() const { return board_; }
  const BoardStats &stats() const { return stats_; }

  // Called from: the main thread, once. Sets the board's watchdog to the protocol default and
  // starts the reader and writer threads.
  void start();
  // Called from: the main thread. The writer drains what is queued, sends stop-all and exits;
  // the reader exits. Every board is asked first, then joined, so that one stuck link does not
  // keep the others from their stop-all.
  void request_stop_writer();
  void join_writer();
  void request_stop_reader();
  void join_reader();

  // Called from: the engine thread. Motor u.motor (the board's own index) takes u.period_q8.
  // Budget: a few us (one Coalescer copy, one frame encoded, one non-blocking write).
  void post(const MotorUpdate &u);

  // Called from: the main thread. Parks the writer and reader off the link (the writer keeps
  // collecting the latest state per motor), waiting up to timeout_ms; false when they did not
  // park in time. attach hands them a new link to the same kind of board (the caller owns it
  // and said hello): the writer sets the watchdog, restores every motor that should sound and
  // carries on.
  bool detach(int timeout_ms);
  void attach(Link *link);

  // Jam (see LiveSession::send_song_frame). Called from: the song player's thread.
  bool queue_song_frame(const uint8_t *wire, size_t n);
  // When the writer handed the last queued song frame to the OS (monotonic_us), once it has,
  // waiting up to timeout_ms; 0 on timeout, or when the frame was dropped (no link).
  uint64_t song_frame_written_us(int timeout_ms);
  long read_replies(uint8_t *out, size_t len, int timeout_ms);
  // Called from: setup code, before start(): the reader keeps the board's bytes for
  // read_replies.
  void forward_replies() { forward_ = true; }
  // Bit m: the board's motor m plays a song (live's setlist) and the live path leaves it alone:
  // post() drops its updates and the writer's refresh skips it. Called from: the main thread.
  void set_song_motors(uint8_t mask) noexcept { song_motors_.store(mask, std::memory_order_release); }
  // True while the board has a link (attached, not detached since). Called from: any thread.
  bool attached() const noexcept;

 private:
  bool try_send_now(const MotorUpdate &u);                          // engine thread
  void writer_loop();                                               // writer thread
  void reader_loop();                                               // reader thread
  void send_pending(Link &link);                                    // owner
  bool send_payload(Link &link, const uint8_t *payload, uint8_t len);  // owner
  bool send_wire(Link &link, const uint8_t *wire, uint8_t len, bool nonblocking);  // owner
  void assert_owned() const noexcept;

  LiveBoard board_;
  LatencyHistogram &latency_;
  std::atomic<int> &realtime_;
  int refresh_ms_;
  std::atomic<Link *> link_{nullptr};
  // detach() bumps detach_gen_; each thread, once it no longer touches the link, copies it to
  // its parked gen; attach() sets attach_gen_ = detach_gen_.
  std::atomic<uint32_t> detach_gen_{0}, attach_gen_{0}, writer_parked_gen_{0}, reader_parked_gen_{0};
  UpdateQueue updates_{kUpdateQueueEntries};
  std::atomic<bool> owned_{false};        // who may touch the link, coalescer and budget
  Coalescer coalescer_;
  LinkBudget budget_;
  std::atomic<uint64_t> absorbed_{0};     // updates the writer took from updates_
  uint64_t enqueued_ = 0;                 // updates the engine put in updates_ (engine only)
  BoardStats stats_;
  std::atomic<bool> stop_writer_{false}, stop_reader_{false};
  std::thread writer_, reader_;
  moodycamel::ReaderWriterQueue<WireFrame> song_{kSongFrames};
  moodycamel::BlockingReaderWriterQueue<ReplyChunk> replies_{kReplyChunks};
  ReplyChunk partial_;                    // read_replies: a chunk taken but not all handed out
  size_t partial_pos_ = 0;
  bool forward_ = false;
  std::atomic<uint8_t> song_motors_{0};
  uint64_t song_queued_ = 0;                 // song frames queued (the song player's thread)
  std::atomic<uint64_t> song_written_{0};    // song frames the writer handed to the OS
  std::atomic<uint64_t> song_written_us_{0}; // when it handed over the last one
  friend class LinkOwnership;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_BOARD_LINK_H

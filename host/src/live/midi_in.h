// midi_in.h: the MIDI input adapter: MIDI input ports in, timestamped MidiEvents into a lock-free
// queue. ALSA ports through RtMidi, JACK ports through JackMidiInput (jack_midi_input.h).
//
// The MIDI callback is the first link of the live path. It runs on RtMidi's ALSA input thread or
// JACK's process thread and does three things only: read the clock, build a
// fixed-size MidiEvent, try_enqueue it. It never allocates, locks, blocks or logs; when the
// queue is full it counts the event as dropped. Debug builds assert that it does not allocate
// (rt_guard.h).
#ifndef STEPCHOIR_HOST_MIDI_IN_H
#define STEPCHOIR_HOST_MIDI_IN_H

#include <readerwriterqueue/readerwriterqueue.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/midi_event.h"

class RtMidiIn;

namespace stepchoir {

class JackMidiInput;

// Single producer (the MIDI callback), single consumer (the engine thread). try_enqueue on a
// queue built with a capacity never allocates; the blocking flavour lets the engine sleep
// until an event comes (a lightweight semaphore: an atomic, and a futex wake when it sleeps).
using MidiQueue = moodycamel::BlockingReaderWriterQueue<MidiEvent>;

// A MIDI clock message (kMidiClockTick, kMidiClockStart, kMidiClockContinue, kMidiClockStop,
// kMidiSongPosition with its position in sixteenths) and when it came (monotonic_us). The MIDI
// callback fills the queue (route_clock), the song player drains it (player/midi_clock.h).
struct ClockMessage {
  uint8_t status = 0;
  uint16_t position = 0;
  uint64_t t_us = 0;
};
using ClockQueue = moodycamel::ReaderWriterQueue<ClockMessage>;

// A raw message -> ClockMessage stamped t_us; false for anything else. Called from: the MIDI
// callback (and tests). Does not allocate.
bool parse_clock_message(const unsigned char *bytes, size_t len, uint64_t t_us, ClockMessage *out) noexcept;

enum class MidiApi : uint8_t { kAlsa, kJack };

// "alsa" / "jack" -> MidiApi; throws std::invalid_argument naming the value otherwise.
// Called from: command-line parsing.
MidiApi parse_midi_api(const std::string &name);

// Names of the MIDI input ports `api` offers now, in index order. Throws std::runtime_error
// when the API cannot start (no ALSA sequencer, no JACK server).
// Called from: `stepchoir ports`, MidiIn's constructor.
std::vector<std::string> list_midi_inputs(MidiApi api);

// The monotonic clock the whole live path stamps with, in microseconds.
// Called from: the MIDI callback, the engine and writer threads. Does not allocate or block.
uint64_t monotonic_us() noexcept;

// A raw MIDI message as the MIDI system delivers it -> MidiEvent stamped t_us. False for anything but a
// channel message (status 0x80-0xEF with its data bytes); data bytes are masked to 7 bits.
// Called from: the MIDI callback (and tests). Does not allocate.
bool parse_midi_message(const unsigned char *bytes, size_t len, uint64_t t_us, MidiEvent *out) noexcept;

// One open MIDI input, feeding a MidiQueue until destroyed.
class MidiIn {
 public:
  // Opens `selector` on `api`: "virtual" or "virtual:NAME" makes a virtual input port (other
  // programs connect to it; NAME defaults to "stepchoir in"); all digits is a port index;
  // anything else is a case-insensitive substring of a port name (the first match). Throws
  // std::runtime_error naming the selector and the ports there are.
  // Called from: setup code (the main thread), before the engine runs.
  MidiIn(MidiApi api, const std::string &selector, MidiQueue &queue);
  // A MidiIn with no port: nothing calls on_message but its owner (tests drive the callback's
  // work directly with it). Called from: tests.
  static std::unique_ptr<MidiIn> without_port(MidiQueue &queue);
  ~MidiIn();
  MidiIn(const MidiIn &) = delete;
  MidiIn &operator=(const MidiIn &) = delete;

  // What was opened, for messages.
  const std::string &port_name() const { return port_name_; }
  // False once the port opened by name or index is no longer offered (the keyboard was
  // unplugged, the program owning it quit); a virtual port is always there.
  // Called from: the main thread, about once a second. Asks the MIDI system: not real-time.
  bool still_there();
  // Events lost because the queue was full. Called from: any thread.
  uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  // From now on the clock's messages go to `queue` too (built with a capacity: the callback
  // only try_enqueues; one a song player, at most kClockQueues), timing messages no longer
  // ignored. Called from: setup code, before the song plays (jam --midi-clock).
  static constexpr size_t kClockQueues = 8;
  void route_clock(ClockQueue &queue);
  // Clock messages lost because their queue was full. Called from: any thread.
  uint64_t clock_dropped() const { return clock_dropped_.load(std::memory_order_relaxed); }
  // How much earlier than it came a clock message is taken to have been sent, us: half the
  // JACK server's period on the JACK API (a message waits for the next cycle), else 0.
  // Called from: any thread.
  uint64_t clock_delay_us() const { return clock_delay_us_; }
  // Channel messages enqueued so far. Called from: any thread.
  uint64_t received() const { return received_.load(std::memory_order_relaxed); }

  // The callback's work on one raw message. Called from: the MIDI callback. Does not
  // allocate, lock, block or log.
  void on_message(const unsigned char *bytes, size_t len) noexcept;

 private:
  explicit MidiIn(MidiQueue &queue);  // no port: see without_port
  void open_jack(const std::string &selector);
  std::unique_ptr<RtMidiIn> in_;         // ALSA
  std::unique_ptr<JackMidiInput> jack_;  // JACK
  std::string jack_source_;              // the JACK port listened to; empty for a virtual port
  MidiQueue &queue_;
  std::string port_name_;
  bool is_virtual_ = false;
  uint64_t clock_delay_us_ = 0;  // set before the callback runs
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> received_{0};
  std::atomic<ClockQueue *> clock_[kClockQueues] = {};
  std::atomic<uint64_t> clock_dropped_{0};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_MIDI_IN_H

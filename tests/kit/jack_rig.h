// jack_rig.h: a private JACK server (dummy driver) and a test MIDI keyboard on it, for the
// live end-to-end test and the live latency benchmark.
#ifndef STEPCHOIR_TESTS_JACK_RIG_H
#define STEPCHOIR_TESTS_JACK_RIG_H

#include <RtMidi.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "board/child_process.h"
#include "core/midi_event.h"
#include "live/jack_period.h"

// A private JACK server with the dummy driver, no realtime; JACK clients of this process and
// its children find it through JACK_DEFAULT_SERVER.
class JackServer {
 public:
  // period_frames: the dummy driver's period in frames at rate_hz (1024 at 48 kHz: 21 ms; MIDI
  // moves once a period). realtime: SCHED_FIFO for the server and its clients' process threads
  // (the benchmark; the tests run without, as a user without realtime privileges would).
  explicit JackServer(int period_frames, bool realtime = false, int rate_hz = 48000)
      : name_("stepchoir-e2e-" + std::to_string(getpid())) {
    setenv("JACK_DEFAULT_SERVER", name_.c_str(), 1);
    setenv("JACK_NO_AUDIO_RESERVATION", "1", 1);
    jackd_ = std::make_unique<stepchoir::ChildProcess>(
        std::vector<std::string>{"/usr/bin/jackd", "-n", name_, realtime ? "-R" : "-r", "-d", "dummy", "-r",
                                 std::to_string(rate_hz), "-p", std::to_string(period_frames)},
        false);
    stepchoir::ChildProcess wait({"/usr/bin/jack_wait", "-s", name_, "-w", "-t", "30"}, true);
    if (wait.wait() != 0) throw std::runtime_error("jackd -n " + name_ + " did not come up");
  }
  ~JackServer() { jackd_->signal_and_wait(SIGTERM); }

 private:
  std::string name_;
  std::unique_ptr<stepchoir::ChildProcess> jackd_;
};

// The test's MIDI keyboard: a virtual JACK MIDI output that `stepchoir live` connects to.
class Sender {
 public:
  static constexpr const char *kPort = "e2e-keys";
  Sender() : out_(RtMidi::UNIX_JACK, "stepchoir e2e sender") { out_.openVirtualPort(kPort); }
  // Closes the port (the keyboard is gone from here on), then waits out the JACK cycle in
  // flight before the RtMidiOut goes. RtMidi 5.0's JACK output frees its ring buffer before it
  // closes its client, and a cycle that began before the port closed still reads that buffer
  // (SIGSEGV in jack_ringbuffer_peek on the client's process thread); a cycle that begins after
  // returns at once.
  ~Sender() {
    out_.closePort();
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int64_t>(2 * stepchoir::jack_period_us())) +
                                kCycleDrain);
  }
  Sender(const Sender &) = delete;
  Sender &operator=(const Sender &) = delete;
  // Sends one channel message; returns when it was sent (s on the steady clock).
  double send(const stepchoir::MidiEvent &e) {
    const unsigned char m[3] = {e.status, e.data1, e.data2};
    out_.sendMessage(m, 3);
    return now_s();
  }
  // Sends a one-byte system message (a MIDI clock's tick, Start, Stop, Continue).
  double send_byte(uint8_t status) {
    out_.sendMessage(&status, 1);
    return now_s();
  }
  static double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  // One key of a script: pressed at on_s, released at off_s (s from the script's start).
  struct Key {
    double on_s, off_s;
    uint8_t note;
  };
  // Plays a script on channel 1 at velocity 64 (below [velocity] double_at: one motor a key),
  // each event at its time from now; returns when the last was sent.
  void play(const std::vector<Key> &script) {
    const double t0 = now_s();
    std::vector<std::pair<double, stepchoir::MidiEvent>> events;
    for (const Key &k : script) {
      events.push_back({k.on_s, stepchoir::note_on(0, k.note, 64)});
      events.push_back({k.off_s, stepchoir::note_off(0, k.note)});
    }
    std::stable_sort(events.begin(), events.end(), [](const auto &a, const auto &b) { return a.first < b.first; });
    for (const auto &e : events) {
      const double wait = t0 + e.first - now_s();
      if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
      send(e.second);
    }
  }

 private:
  // Beyond two periods, for a process thread the machine held up (without realtime scheduling).
  static constexpr std::chrono::milliseconds kCycleDrain{50};
  RtMidiOut out_;
};

#endif  // STEPCHOIR_TESTS_JACK_RIG_H

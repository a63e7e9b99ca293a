// jack_midi_input.h: MIDI input straight from JACK, for MidiIn on the JACK API.
//
// RtMidi's JACK input reads every event of a cycle without checking jack_midi_event_get: when a
// cycle overruns (an xrun) and the port's buffer is rewritten while it reads, it takes a garbage
// event and dereferences its pointer (a crash seen under stepchoir-bench-live at 96 kHz,
// 8 frames; docs/decisions/026-jack-midi-input.md). Here each event is read with its result
// checked, and its bytes are used only when they lie inside the port's buffer.
#ifndef STEPCHOIR_HOST_LIVE_JACK_MIDI_INPUT_H
#define STEPCHOIR_HOST_LIVE_JACK_MIDI_INPUT_H

#include <jack/jack.h>
#include <jack/midiport.h>

#include <atomic>
#include <cstddef>
#include <string>
#include <vector>

namespace stepchoir {

// The longest event passed on: a channel message, a clock message or a song position (sysex
// and longer are no use to the live path and are skipped).
constexpr size_t kJackMidiMaxBytes = 3;

// True when the event's bytes lie inside the port buffer [buf, buf + buffer_bytes) and it is
// 1 to kJackMidiMaxBytes long. Called from: the process callback (and tests). Does not allocate.
bool jack_event_usable(const jack_midi_event_t &event, const void *buf, size_t buffer_bytes) noexcept;

class JackMidiInput {
 public:
  // Called from: JACK's process thread, for each usable event, with its bytes. Must not
  // allocate, lock, block or log.
  using Handler = void (*)(const unsigned char *bytes, size_t len, void *user) noexcept;

  // Opens a JACK client named client_name (JACK makes it unique); never starts a server.
  // Throws std::runtime_error when no server runs. Called from: setup code (the main thread).
  JackMidiInput(const std::string &client_name, Handler handler, void *user);
  // Deactivates and closes the client: JACK waits out a process callback in flight first.
  ~JackMidiInput();
  JackMidiInput(const JackMidiInput &) = delete;
  JackMidiInput &operator=(const JackMidiInput &) = delete;

  // Other clients' MIDI output ports, the sources an input can listen to, in JACK's order.
  // Called from: the main thread.
  std::vector<std::string> sources() const;
  // Registers the input port `port_name` and starts the client; with a source, connects that
  // source to it. Throws std::runtime_error naming what failed. Called from: setup code, once.
  void open(const std::string &port_name, const std::string &source);
  // False once `source` is no longer offered, or the server went away. Called from: the main
  // thread, about once a second.
  bool still_there(const std::string &source) const;

 private:
  static int process(jack_nframes_t frames, void *arg) noexcept;
  static void on_shutdown(void *arg) noexcept;

  jack_client_t *client_ = nullptr;
  jack_port_t *port_ = nullptr;  // set before the client is activated
  size_t buffer_bytes_ = 0;      // a MIDI port buffer's size, bytes
  Handler handler_;
  void *user_;
  std::atomic<bool> server_gone_{false};
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_JACK_MIDI_INPUT_H

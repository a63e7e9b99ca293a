// jack_midi_input.cpp: see jack_midi_input.h.
#include "live/jack_midi_input.h"

#include <stdexcept>

#include "live/rt_guard.h"

namespace stepchoir {

bool jack_event_usable(const jack_midi_event_t &event, const void *buf, size_t buffer_bytes) noexcept {
  if (event.size < 1 || event.size > kJackMidiMaxBytes || !event.buffer) return false;
  const auto *first = static_cast<const unsigned char *>(buf), *bytes = event.buffer;
  return bytes >= first && bytes + event.size <= first + buffer_bytes;
}

JackMidiInput::JackMidiInput(const std::string &client_name, Handler handler, void *user)
    : handler_(handler), user_(user) {
  jack_status_t status;
  client_ = jack_client_open(client_name.c_str(), JackNoStartServer, &status);
  if (!client_) throw std::runtime_error("no JACK server is running (jackd, or pipewire-jack)");
  buffer_bytes_ = jack_port_type_get_buffer_size(client_, JACK_DEFAULT_MIDI_TYPE);
  jack_on_shutdown(client_, on_shutdown, this);
}

JackMidiInput::~JackMidiInput() {
  if (!client_) return;
  jack_deactivate(client_);
  jack_client_close(client_);
}

std::vector<std::string> JackMidiInput::sources() const {
  std::vector<std::string> out;
  const char **ports = jack_get_ports(client_, nullptr, JACK_DEFAULT_MIDI_TYPE, JackPortIsOutput);
  if (!ports) return out;
  for (size_t i = 0; ports[i]; ++i) out.emplace_back(ports[i]);
  jack_free(ports);
  return out;
}

void JackMidiInput::open(const std::string &port_name, const std::string &source) {
  port_ = jack_port_register(client_, port_name.c_str(), JACK_DEFAULT_MIDI_TYPE, JackPortIsInput, 0);
  if (!port_) throw std::runtime_error("JACK refused the input port '" + port_name + "'");
  if (jack_set_process_callback(client_, process, this) != 0 || jack_activate(client_) != 0)
    throw std::runtime_error("JACK would not start the client");
  if (!source.empty() && jack_connect(client_, source.c_str(), jack_port_name(port_)) != 0)
    throw std::runtime_error("JACK would not connect '" + source + "' to '" + jack_port_name(port_) + "'");
}

bool JackMidiInput::still_there(const std::string &source) const {
  if (server_gone_.load(std::memory_order_acquire)) return false;
  return source.empty() || jack_port_by_name(client_, source.c_str()) != nullptr;
}

// Called from: JACK's process thread, once a period (budget: well under the period; a few
// hundred ns an event). Reads each event with its result checked and hands the usable ones on.
int JackMidiInput::process(jack_nframes_t frames, void *arg) noexcept {
  RtScope rt;
  auto *self = static_cast<JackMidiInput *>(arg);
  void *buf = jack_port_get_buffer(self->port_, frames);
  if (!buf) return 0;
  const uint32_t count = jack_midi_get_event_count(buf);
  for (uint32_t i = 0; i < count; ++i) {
    jack_midi_event_t event;
    if (jack_midi_event_get(&event, buf, i) != 0) break;  // the buffer changed under us
    if (!jack_event_usable(event, buf, self->buffer_bytes_)) continue;
    unsigned char bytes[kJackMidiMaxBytes];
    for (size_t b = 0; b < event.size; ++b) bytes[b] = event.buffer[b];
    self->handler_(bytes, event.size, self->user_);
  }
  return 0;
}

// Called from: a JACK thread when the server shuts the client down.
void JackMidiInput::on_shutdown(void *arg) noexcept {
  static_cast<JackMidiInput *>(arg)->server_gone_.store(true, std::memory_order_release);
}

}  // namespace stepchoir

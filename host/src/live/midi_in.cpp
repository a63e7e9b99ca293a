// midi_in.cpp: MIDI input ports (RtMidi's ALSA, JackMidiInput's JACK) -> MidiQueue.
#include "live/midi_in.h"

#include <RtMidi.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <stdexcept>

#include "live/jack_midi_input.h"
#include "live/jack_period.h"
#include "live/rt_guard.h"

namespace stepchoir {
namespace {

// Called from: MidiIn and list_midi_inputs. RtMidi's enum for ours.
RtMidi::Api rtmidi_api(MidiApi api) { return api == MidiApi::kJack ? RtMidi::UNIX_JACK : RtMidi::LINUX_ALSA; }

// Called from: error messages. The API's name as the command line spells it.
const char *api_name(MidiApi api) { return api == MidiApi::kJack ? "jack" : "alsa"; }

// Called from: RtMidi's thread for every message. Hands it to MidiIn::on_message.
void rtmidi_callback(double, std::vector<unsigned char> *message, void *user) {
  static_cast<MidiIn *>(user)->on_message(message->data(), message->size());
}

// Called from: JACK's process thread for every usable message. Hands it to MidiIn::on_message.
void jack_callback(const unsigned char *bytes, size_t len, void *user) noexcept {
  static_cast<MidiIn *>(user)->on_message(bytes, len);
}

// Called from: RtMidi on a port error after opening. Nothing to do on that thread: the
// engine sees the silence, and the status line shows the input count no longer moving.
void rtmidi_error(RtMidiError::Type, const std::string &, void *) {}

// Called from: selector matching. Lower-case copy.
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

MidiApi parse_midi_api(const std::string &name) {
  if (name == "alsa") return MidiApi::kAlsa;
  if (name == "jack") return MidiApi::kJack;
  throw std::invalid_argument("MIDI API '" + name + "': expected alsa or jack");
}

uint64_t monotonic_us() noexcept {
  return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                   std::chrono::steady_clock::now().time_since_epoch())
                                   .count());
}

namespace {

// Called from: MidiIn's constructor. The index of the port `selector` names among `names`: all
// digits is an index, anything else a case-insensitive substring (the first match). Throws
// std::runtime_error naming the selector and the ports there are.
int pick_port(const std::string &selector, const std::vector<std::string> &names, MidiApi api) {
  int index = -1;
  if (!selector.empty() && std::all_of(selector.begin(), selector.end(), ::isdigit)) {
    const unsigned long i = std::stoul(selector);
    if (i < names.size()) index = static_cast<int>(i);
  } else {
    for (size_t i = 0; i < names.size() && index < 0; ++i)
      if (lower(names[i]).find(lower(selector)) != std::string::npos) index = static_cast<int>(i);
  }
  if (index >= 0) return index;
  std::string list;
  for (size_t i = 0; i < names.size(); ++i) list += "\n  " + std::to_string(i) + ": " + names[i];
  throw std::runtime_error("--midi '" + selector + "': no such " + api_name(api) + " MIDI input" +
                           (names.empty() ? std::string("; there are none") : "; there are:" + list) +
                           "\n  (or use --midi virtual)");
}

// "virtual" or "virtual:NAME" -> the virtual port's name (NAME, else "stepchoir in"); false for
// any other selector.
bool virtual_port(const std::string &selector, std::string *name) {
  if (selector != "virtual" && selector.rfind("virtual:", 0) != 0) return false;
  *name = selector.size() > 8 ? selector.substr(8) : "stepchoir in";
  return true;
}

}  // namespace

std::vector<std::string> list_midi_inputs(MidiApi api) {
  try {
    if (api == MidiApi::kJack) return JackMidiInput("stepchoir ports", jack_callback, nullptr).sources();
    RtMidiIn in(rtmidi_api(api), "stepchoir ports");
    std::vector<std::string> out;
    for (unsigned i = 0, n = in.getPortCount(); i < n; ++i) out.push_back(in.getPortName(i));
    return out;
  } catch (const RtMidiError &e) {
    throw std::runtime_error(std::string("MIDI (") + api_name(api) + "): " + e.getMessage());
  } catch (const std::runtime_error &e) {
    throw std::runtime_error(std::string("MIDI (") + api_name(api) + "): " + e.what());
  }
}

MidiIn::MidiIn(MidiApi api, const std::string &selector, MidiQueue &queue) : queue_(queue) {
  if (api == MidiApi::kJack) {
    clock_delay_us_ = static_cast<uint64_t>(jack_period_us() / 2);
    open_jack(selector);
    return;
  }
  try {
    in_ = std::make_unique<RtMidiIn>(rtmidi_api(api), "stepchoir");
    in_->setErrorCallback(rtmidi_error, this);
    in_->ignoreTypes(true, true, true);  // sysex, clock, active sensing: never reach the queue
    in_->setCallback(rtmidi_callback, this);
    if (virtual_port(selector, &port_name_)) {
      in_->openVirtualPort(port_name_);
      port_name_ = std::string("virtual port '") + port_name_ + "'";
      is_virtual_ = true;
      return;
    }
    std::vector<std::string> names;
    for (unsigned i = 0, count = in_->getPortCount(); i < count; ++i) names.push_back(in_->getPortName(i));
    const int index = pick_port(selector, names, api);
    in_->openPort(static_cast<unsigned>(index), "stepchoir in");
    port_name_ = names[index];
  } catch (const RtMidiError &e) {
    throw std::runtime_error(std::string("MIDI (") + api_name(api) + "): " + e.getMessage());
  }
}

// The JACK API: a client of our own (jack_midi_input.h), its input port connected to the
// selected source, or left for other programs to connect to (virtual). Sysex never reaches
// the callback; clock messages do, and on_message drops them until route_clock.
void MidiIn::open_jack(const std::string &selector) {
  try {
    jack_ = std::make_unique<JackMidiInput>("stepchoir", jack_callback, this);
    if (virtual_port(selector, &port_name_)) {
      jack_->open(port_name_, "");
      port_name_ = std::string("virtual port '") + port_name_ + "'";
      is_virtual_ = true;
      return;
    }
    const std::vector<std::string> names = jack_->sources();
    jack_source_ = names[pick_port(selector, names, MidiApi::kJack)];
    jack_->open("stepchoir in", jack_source_);
    port_name_ = jack_source_;
  } catch (const std::runtime_error &e) {
    jack_.reset();
    const std::string what = e.what();
    throw std::runtime_error(what.rfind("--midi", 0) == 0 ? what : "MIDI (jack): " + what);
  }
}

MidiIn::MidiIn(MidiQueue &queue) : queue_(queue) {}

std::unique_ptr<MidiIn> MidiIn::without_port(MidiQueue &queue) {
  return std::unique_ptr<MidiIn>(new MidiIn(queue));
}

bool MidiIn::still_there() {
  if (jack_) return jack_->still_there(jack_source_);
  if (is_virtual_ || !in_) return true;
  try {
    for (unsigned i = 0, n = in_->getPortCount(); i < n; ++i)
      if (in_->getPortName(i) == port_name_) return true;
  } catch (const RtMidiError &) {
  }
  return false;
}

// RtMidi's input closes its port and then its ALSA thread, and JackMidiInput deactivates its
// client: each waits out a callback in flight. The callback stays set meanwhile (RtMidi's
// cancelCallback first would let a callback in flight read it after it was cleared, and call a
// null one), and every member it touches is still alive here.
MidiIn::~MidiIn() {
  in_.reset();
  jack_.reset();
}

bool parse_midi_message(const unsigned char *bytes, size_t len, uint64_t t_us, MidiEvent *out) noexcept {
  if (len < 1 || bytes[0] < 0x80 || bytes[0] >= 0xF0) return false;
  // Program change (0xC0) and channel pressure (0xD0) carry one data byte, the others two.
  const uint8_t type = bytes[0] & 0xF0;
  const size_t need = (type == 0xC0 || type == 0xD0) ? 2 : 3;
  if (len < need) return false;
  *out = MidiEvent{bytes[0], static_cast<uint8_t>(bytes[1] & 0x7F),
                   static_cast<uint8_t>(need > 2 ? bytes[2] & 0x7F : 0), t_us};
  return true;
}

bool parse_clock_message(const unsigned char *bytes, size_t len, uint64_t t_us, ClockMessage *out) noexcept {
  if (len < 1) return false;
  const uint8_t s = bytes[0];
  if (s == kMidiSongPosition) {
    if (len < 3) return false;
    *out = ClockMessage{s, static_cast<uint16_t>((bytes[1] & 0x7F) | ((bytes[2] & 0x7F) << 7)), t_us};
    return true;
  }
  if (s != kMidiClockTick && s != kMidiClockStart && s != kMidiClockContinue && s != kMidiClockStop) return false;
  *out = ClockMessage{s, 0, t_us};
  return true;
}

// The JACK input passes clock messages always; on_message drops them while no queue is set.
void MidiIn::route_clock(ClockQueue &queue) {
  for (auto &slot : clock_) {
    ClockQueue *none = nullptr;
    if (slot.compare_exchange_strong(none, &queue)) break;
  }
  if (in_) in_->ignoreTypes(true, false, true);  // sysex and active sensing still ignored
}

void MidiIn::on_message(const unsigned char *bytes, size_t len) noexcept {
  RtScope rt;
  ClockMessage m;
  if (parse_clock_message(bytes, len, monotonic_us() - clock_delay_us_, &m)) {
    for (auto &slot : clock_)
      if (ClockQueue *q = slot.load(std::memory_order_acquire))
        if (!q->try_enqueue(m)) clock_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;  // (a clock message is no channel message)
  }
  MidiEvent ev;
  if (!parse_midi_message(bytes, len, monotonic_us(), &ev)) return;
  if (queue_.try_enqueue(ev))
    received_.fetch_add(1, std::memory_order_relaxed);
  else
    dropped_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace stepchoir

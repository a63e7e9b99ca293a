// test_live.cpp: `stepchoir live` end to end, no fakes: a JACK server (dummy driver), a test
// sender on a JACK MIDI port, the stepchoir process reading it through its own JACK client, and
// the real firmware on the virtual board. The board's trace must show every note at its pitch on
// some motor, started and released on time (chords, velocity-0 note-offs, sustain, bends);
// after hundreds of random events nothing may sound; SIGTERM must silence a held note at once.
// Then: board unplugged and back, keyboard unplugged and back, two boards in one pool. The rig
// file's part: test_live_rig.cpp.
#include <catch2/catch.hpp>

#include <RtMidi.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "core/midi_event.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "live_checks.h"
#include "trace.h"

namespace tr = sc::trace;
using stepchoir::MidiEvent;
using namespace live_checks;

namespace {

// Silence between the random phase and the last held note (sender clock, s).
const double kQuietGapS = 1.0;

// A note the trace must show: pitch (fractional MIDI note, bend included), from on_s to off_s
// on the sender's clock.
struct Expected {
  double pitch;
  double on_s, off_s;
};

// Sleeps until `t_s` on the steady clock.
void sleep_until_s(double t_s) {
  const double left = t_s - Sender::now_s();
  if (left > 0) std::this_thread::sleep_for(std::chrono::duration<double>(left));
}

}  // namespace

TEST_CASE("live: a JACK keyboard plays the virtual board through stepchoir live", "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("live.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // Not --quiet: with stdout not a terminal the status line comes once a second, on its own line.
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--midi-api", "jack", "--midi", Sender::kPort, "--port", vb.pty()}, true);
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  INFO("stepchoir live said: " << line);
  REQUIRE(line.rfind("live: MIDI", 0) == 0);
  REQUIRE(line.find("-> 4 motors") != std::string::npos);

  // Phase 1: a script, every event 150-300 ms apart, so each note is its own segment.
  using stepchoir::control_change;
  using stepchoir::note_off;
  using stepchoir::note_on;
  using stepchoir::pitch_bend;
  const double t0 = Sender::now_s() + 0.3;
  std::vector<Expected> expected;
  size_t sent = 0;
  auto at = [&](double t, const MidiEvent &e) {
    sleep_until_s(t0 + t);
    ++sent;
    return keys.send(e);
  };
  double on = at(0.0, note_on(0, 60, 100));
  double off = at(0.3, note_off(0, 60));
  expected.push_back({60, on, off});
  std::vector<double> chord_on;
  for (uint8_t n : {64, 67, 71}) chord_on.push_back(at(0.45, note_on(0, n, 90)));
  double off64 = at(0.85, note_on(0, 64, 0));  // velocity 0: a note-off
  double off67 = at(0.85, note_off(0, 67));
  double off71 = at(0.85, note_off(0, 71));
  expected.push_back({64, chord_on[0], off64});
  expected.push_back({67, chord_on[1], off67});
  expected.push_back({71, chord_on[2], off71});
  at(1.0, control_change(0, stepchoir::kCcSustain, 127));
  on = at(1.0, note_on(0, 62, 100));
  at(1.3, note_off(0, 62));  // the pedal holds it
  off = at(1.6, control_change(0, stepchoir::kCcSustain, 0));
  expected.push_back({62, on, off});
  at(1.8, pitch_bend(0, 8192 + 4096));  // +1 semitone of the default +/-2
  on = at(1.8, note_on(0, 65, 100));
  const double centre = at(2.1, pitch_bend(0, 8192));
  off = at(2.4, note_off(0, 65));
  expected.push_back({66, on, centre});
  expected.push_back({65, centre, off});
  const double script_end = off;

  // Phase 2: 1,500 random events (about 700 notes) on two channels: notes, chords, sustain,
  // bends; then every key up, pedals up, bends centred (no all-notes-off: the host must get
  // there by itself).
  std::mt19937 rng(12345);
  std::set<std::pair<uint8_t, uint8_t>> held;
  double t = 2.7;
  for (int i = 0; i < 1500; ++i) {
    t += 0.004 + 0.008 * std::uniform_real_distribution<double>(0, 1)(rng);
    const uint8_t ch = static_cast<uint8_t>(rng() % 2);
    const unsigned kind = rng() % 20;
    if (kind < 9 || held.empty()) {
      const uint8_t n = static_cast<uint8_t>(36 + rng() % 60);
      held.insert({ch, n});
      at(t, note_on(ch, n, static_cast<uint8_t>(1 + rng() % 127)));
    } else if (kind < 17) {
      auto it = held.begin();
      std::advance(it, rng() % held.size());
      at(t, rng() % 3 ? note_off(it->first, it->second) : note_on(it->first, it->second, 0));
      held.erase(it);
    } else if (kind < 19) {
      at(t, control_change(ch, stepchoir::kCcSustain, rng() % 2 ? 127 : 0));
    } else {
      at(t, pitch_bend(ch, static_cast<uint16_t>(rng() % 16384)));
    }
  }
  for (const auto &k : held) at(t, note_off(k.first, k.second));
  for (uint8_t ch = 0; ch < 2; ++ch) {
    at(t, control_change(ch, stepchoir::kCcSustain, 0));
    at(t, pitch_bend(ch, 8192));
  }
  const double random_end = Sender::now_s();

  // Phase 3: a held note, then SIGTERM: the motor must stop at once (the watchdog would take
  // 300 ms). The second of silence before it is where a stuck note would show.
  sleep_until_s(random_end + kQuietGapS);
  const double held_on = keys.send(note_on(0, 72, 100));
  ++sent;
  sleep_until_s(held_on + 0.4);
  const double term_s = Sender::now_s();
  const int live_rc = live.signal_and_wait(SIGTERM);
  const std::string live_out = live.read_rest(2000);
  sleep_until_s(term_s + 0.5);
  REQUIRE(vb.stop() == 0);
  INFO("stepchoir live output:\n" << live_out);
  CHECK(live_rc == 0);
  CHECK(live_out.find("live: every motor silenced (" + std::to_string(sent) + " events") != std::string::npos);
  CHECK(live_out.find("m0 ") != std::string::npos);
  CHECK(live_out.find("| " + vb.pty() + " ok, ") != std::string::npos);
  CHECK(live_out.find(" events, latency p50 ") != std::string::npos);

  const tr::Trace trace = tr::read_trace(trace_path);
  const std::vector<Played> played = played_notes(trace);
  REQUIRE_FALSE(played.empty());
  // On a loaded machine the simulation falls behind the wall clock and catches up later, so
  // board time and sender time drift apart by up to the board's worst pacing lag: timing
  // checks allow for it, and each note is found near where the previous one was found.
  const double lag_s = pacing_error_s(trace);
  const double tolerance_s = kTimeToleranceS + lag_s;
  INFO("virtual board's pacing error (worst lag + slip): " << lag_s * 1e3 << " ms");
  double offset = played.front().start_s - expected.front().on_s;  // board clock - sender clock
  for (const Expected &e : expected) {
    const Played *match = nullptr;
    for (const Played &p : played)
      if (std::fabs(p.pitch - e.pitch) < kPitchToleranceSemitones &&
          std::fabs(p.start_s - offset - e.on_s) < tolerance_s)
        match = &p;
    INFO("note " << e.pitch << " from " << e.on_s - t0 << " s to " << e.off_s - t0 << " s");
    std::string nearby;
    for (const Played &p : played)
      if (std::fabs(p.start_s - offset - e.on_s) < 0.5)
        nearby += "  motor " + std::to_string(p.motor) + " pitch " + std::to_string(p.pitch) + " from " +
                  std::to_string(p.start_s - offset - t0) + " to " + std::to_string(p.end_s - offset - t0) + "\n";
    INFO("played nearby:\n" << nearby);
    REQUIRE(match != nullptr);
    offset = match->start_s - e.on_s;
    // Released on time: the last step comes at most one period before the release.
    const double period_s = 1.0 / tr::hz_from_midi(e.pitch);
    CHECK(std::fabs(match->end_s - offset - e.off_s) < tolerance_s + period_s);
  }
  // Nothing else sounded during the script.
  for (const Played &p : played)
    if (p.start_s - offset < script_end + 0.1) {
      const bool known = std::any_of(expected.begin(), expected.end(), [&](const Expected &e) {
        return std::fabs(p.pitch - e.pitch) < kPitchToleranceSemitones;
      });
      INFO("motor " << p.motor << " played " << p.pitch << " at " << p.start_s - offset - t0 << " s");
      CHECK(known);
    }

  // The held note is the last note of the trace; it sounded until SIGTERM and stopped right
  // after it.
  const Played &held_note = played.back();
  REQUIRE(std::fabs(held_note.pitch - 72) < kPitchToleranceSemitones);
  CHECK(held_note.end_s - held_note.start_s > term_s - held_on - tolerance_s);
  CHECK(held_note.end_s - held_note.start_s < term_s - held_on + tolerance_s + 0.1);
  for (int m = 0; m < trace.motors; ++m) {
    const auto after = tr::steps_in_window(trace.motor[m].steps,
                                           static_cast<uint64_t>((held_note.end_s + 0.001) * trace.f_cpu_hz),
                                           trace.end_cycle + 1);
    INFO("motor " << m << " stepped " << after.size() << " times after the held note ended");
    CHECK(after.size() == 0);
  }

  // The random phase sounded, and nothing was left sounding after its last event: the second
  // before the held note is silent on every motor.
  size_t random_notes = 0;
  for (const Played &p : played) random_notes += p.start_s - offset > script_end + 0.1;
  CHECK(random_notes > 50);
  const double quiet_from_s = held_note.start_s - (kQuietGapS - 0.3);
  for (int m = 0; m < trace.motors; ++m) {
    const auto quiet = tr::steps_in_window(trace.motor[m].steps, static_cast<uint64_t>(quiet_from_s * trace.f_cpu_hz),
                                           static_cast<uint64_t>((held_note.start_s - 0.001) * trace.f_cpu_hz));
    INFO("motor " << m << " stepped " << quiet.size() << " times after the random phase ended");
    CHECK(quiet.size() == 0);
  }
}

TEST_CASE("live: the board unplugged and back: stepchoir live reconnects and restores the held note",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string link = e2e::scratch("live-unplug.pty");
  const std::string trace_before = e2e::scratch("live-unplug-1.csv"), trace_after = e2e::scratch("live-unplug-2.csv");
  // As a real Uno: each open of its port resets it, and its bootloader holds it about 1.4 s,
  // both at the start and when live opens it again.
  auto board = [&](const std::string &trace) {
    return std::make_unique<VboardProcess>(std::vector<std::string>{"--board", "uno", "--auto-reset", "--link", link,
                                                                    "--trace", trace, "--quiet", "--no-measure"});
  };
  auto vb = board(trace_before);
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--midi-api", "jack", "--midi", Sender::kPort, "--port", link, "--quiet"},
                    true);
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  REQUIRE(line.rfind("live: MIDI", 0) == 0);
  settle();

  keys.send(stepchoir::note_on(0, 60, kSoft));  // held across the unplug
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  REQUIRE(vb->stop() == 0);  // unplugged
  REQUIRE(wait_for_line(live, "link lost"));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  vb = board(trace_after);  // plugged in again, same path
  REQUIRE(wait_for_line(live, "reconnected"));
  const double back_s = Sender::now_s();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const double off60_s = keys.send(stepchoir::note_off(0, 60));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const double on64_s = keys.send(stepchoir::note_on(0, 64, kSoft));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double off64_s = keys.send(stepchoir::note_off(0, 64));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb->stop() == 0);

  const tr::Trace before_trace = tr::read_trace(trace_before);
  CHECK(before_trace.mcu_resets.size() == 1);  // live's open reset it, and waited out its bootloader
  const auto before = played_notes(before_trace);
  REQUIRE(before.size() == 1);
  CHECK(std::fabs(before[0].pitch - 60) < kPitchToleranceSemitones);
  const tr::Trace after_trace = tr::read_trace(trace_after);
  CHECK(after_trace.mcu_resets.size() == 1);  // ... and its reopen
  const auto after = played_notes(after_trace);
  const double tolerance_s = kTimeToleranceS + pacing_error_s(after_trace);
  REQUIRE(after.size() == 2);
  // The held note sounds again as soon as the board is back, until its key is released.
  CHECK(std::fabs(after[0].pitch - 60) < kPitchToleranceSemitones);
  CHECK(after[0].end_s - after[0].start_s > off60_s - back_s - tolerance_s);
  CHECK(after[0].end_s - after[0].start_s < off60_s - back_s + 0.2 + tolerance_s);
  // The next note plays in time.
  CHECK(std::fabs(after[1].pitch - 64) < kPitchToleranceSemitones);
  CHECK(std::fabs((after[1].start_s - after[0].end_s) - (on64_s - off60_s)) < tolerance_s);
  CHECK(std::fabs((after[1].end_s - after[1].start_s) - (off64_s - on64_s)) < tolerance_s);
}

TEST_CASE("live: two boards form one pool of motors", "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_uno = e2e::scratch("live-pool-uno.csv"), trace_mega = e2e::scratch("live-pool-mega.csv");
  VboardProcess uno({"--board", "uno", "--trace", trace_uno, "--quiet", "--no-measure"});
  VboardProcess mega({"--board", "mega", "--trace", trace_mega, "--quiet", "--no-measure"});
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--midi-api", "jack", "--midi", Sender::kPort, "--port", uno.pty(), "--port",
                     mega.pty(), "--policy", "channel", "--quiet"},
                    true);
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  INFO("stepchoir live said: " << line);
  REQUIRE(line.find("-> 9 motors") != std::string::npos);
  settle();
  // Channel n plays pool motor n: channel 1 is the Uno's motor 1, channel 6 the Mega's motor 2.
  keys.send(stepchoir::note_on(1, 57, 100));
  keys.send(stepchoir::note_on(6, 76, 100));
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  keys.send(stepchoir::note_off(1, 57));
  keys.send(stepchoir::note_off(6, 76));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(uno.stop() == 0);
  REQUIRE(mega.stop() == 0);

  const auto on_uno = played_notes(tr::read_trace(trace_uno));
  const auto on_mega = played_notes(tr::read_trace(trace_mega));
  REQUIRE(on_uno.size() == 1);
  CHECK(on_uno[0].motor == 1);
  CHECK(std::fabs(on_uno[0].pitch - 57) < kPitchToleranceSemitones);
  REQUIRE(on_mega.size() == 1);
  CHECK(on_mega[0].motor == 2);
  CHECK(std::fabs(on_mega[0].pitch - 76) < kPitchToleranceSemitones);
}

TEST_CASE("live: the keyboard unplugged and back: its held note stops, then it plays again", "[e2e][live][pacing]") {
  JackServer jack(1024);
  auto keys = std::make_unique<Sender>();
  const std::string trace_path = e2e::scratch("live-keyboard.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  stepchoir::ChildProcess live({STEPCHOIR_BIN, "live", "--midi-api", "jack", "--midi", Sender::kPort, "--port", vb.pty(), "--quiet"},
                    true);
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  REQUIRE(line.rfind("live: MIDI", 0) == 0);
  settle();
  keys->send(stepchoir::control_change(0, stepchoir::kCcSustain, 127));
  const double on60_s = keys->send(stepchoir::note_on(0, 60, kSoft));  // down, and pedalled, when unplugged
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double gone_s = Sender::now_s();
  keys.reset();  // unplugged: its port closes at once, its client a little later
  REQUIRE(wait_for_line(live, "is gone"));
  const double noticed_s = Sender::now_s();
  keys = std::make_unique<Sender>();  // plugged in again
  REQUIRE(wait_for_line(live, "is back"));
  settle();
  const double on_s = keys->send(stepchoir::note_on(0, 64, kSoft));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double off_s = keys->send(stepchoir::note_off(0, 64));  // no pedal: it stops here
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);

  const tr::Trace trace = tr::read_trace(trace_path);
  const double tolerance_s = kTimeToleranceS + pacing_error_s(trace);
  const auto played = played_notes(trace);
  REQUIRE(played.size() == 2);
  CHECK(std::fabs(played[0].pitch - 60) < kPitchToleranceSemitones);
  // The held note sounded until the unplug and stopped by the time the keyboard was reported
  // gone (checked once a second).
  const double held_s = played[0].end_s - played[0].start_s;
  CHECK(held_s > gone_s - on60_s - tolerance_s);
  CHECK(held_s < noticed_s - on60_s + tolerance_s);
  CHECK(std::fabs(played[1].pitch - 64) < kPitchToleranceSemitones);
  CHECK(std::fabs((played[1].end_s - played[1].start_s) - (off_s - on_s)) < tolerance_s);
}

// test_expression.cpp: expression on stage, end to end: a JACK keyboard's mod wheel, glide and
// velocity through `stepchoir live` into the real firmware on the virtual board: vibrato at the
// configured rate and depth, a glide for its set time, and a loud note doubled on free motors in
// unison, measured from the trace's STEP edges; each note then plays its exact pitch.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "analysis.h"
#include "board/child_process.h"
#include "core/midi_event.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "trace.h"
#include "vboard_process.h"

namespace tr = sc::trace;

namespace {

// The motor's pitch at each STEP edge (cents against a4 = 440 Hz, one step a cycle) from the
// interval since the edge before, with the edge's real time (s).
std::vector<std::pair<double, double>> cents_by_edge(const tr::Trace &t, size_t motor) {
  std::vector<std::pair<double, double>> out;
  const auto &s = t.motor.at(motor).steps;
  for (size_t i = 1; i < s.size(); ++i) {
    const double dt = t.real_seconds(s[i].rise_cycle) - t.real_seconds(s[i - 1].rise_cycle);
    if (dt > 0.02) continue;  // a silence between notes
    out.push_back({t.real_seconds(s[i].rise_cycle), 1200.0 * std::log2(1.0 / dt / 440.0)});
  }
  return out;
}

// Ends `stepchoir live` (SIGTERM) and the board, and reads the board's trace; the motor that
// stepped most is the one that played.
tr::Trace finish(stepchoir::ChildProcess &live, VboardProcess &vb, const std::string &trace_path, size_t *motor) {
  CHECK(live.signal_and_wait(SIGTERM) == 0);
  REQUIRE(vb.stop() == 0);
  tr::Trace t = tr::read_trace(trace_path);
  *motor = 0;
  for (size_t m = 0; m < t.motor.size(); ++m)
    if (t.motor[m].steps.size() > t.motor[*motor].steps.size()) *motor = m;
  return t;
}

// `stepchoir live` on an Uno virtual board that keeps a trace, played from a JACK keyboard; its
// rig file names the keyboard, the board and holds `tables` (TOML). Ready to play once built.
struct LiveRig {
  LiveRig(const std::string &name, const std::string &tables)
      : trace_path(e2e::scratch(name + ".csv")), config_path(e2e::scratch(name + ".toml")),
        vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"}) {
    std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n"
                               << tables << "[[boards]]\nport = \"" << vb.pty() << "\"\n";
    live = std::make_unique<stepchoir::ChildProcess>(
        std::vector<std::string>{STEPCHOIR_BIN, "live", "--config", config_path, "--quiet"}, true);
    REQUIRE(live->read_line(&said, 30000));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // JACK takes the new connection
  }

  JackServer jack{1024};
  Sender keys;
  std::string trace_path, config_path;
  VboardProcess vb;
  std::unique_ptr<stepchoir::ChildProcess> live;
  std::string said;  // its first line
};

}  // namespace

TEST_CASE("live: the mod wheel sings vibrato at its rate and depth, and the note is back on pitch when it falls",
          "[e2e][live][pacing]") {
  LiveRig rig("vibrato", "[vibrato]\nrate_hz = 5.5\ndepth_cents = 50.0\nfade_ms = 150.0\n");
  INFO("stepchoir live said: " << rig.said);
  Sender &keys = rig.keys;
  keys.send(stepchoir::note_on(0, 69, 100));  // A4
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  keys.send(stepchoir::control_change(0, stepchoir::kCcModWheel, 127));
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  keys.send(stepchoir::control_change(0, stepchoir::kCcModWheel, 0));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  keys.send(stepchoir::note_off(0, 69));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  size_t motor = 0;
  const tr::Trace t = finish(*rig.live, rig.vb, rig.trace_path, &motor);
  const auto cents = cents_by_edge(t, motor);
  REQUIRE(cents.size() > 1000);
  const double start = cents.front().first;
  // Before the wheel: A4 itself. With the wheel up (after its fade-in): the sine. After it falls:
  // A4 again.
  std::vector<std::pair<double, double>> before, during, after;
  for (const auto &[time, c] : cents) {
    const double s = time - start;
    if (s > 0.05 && s < 0.35) before.push_back({s, c});
    if (s > 0.8 && s < 2.8) during.push_back({s, c});
    if (s > 3.05 && s < 3.3) after.push_back({s, c});
  }
  REQUIRE(!before.empty());
  REQUIRE(during.size() > 500);
  REQUIRE(!after.empty());
  // One edge's interval jitters by a microsecond or so (about 0.8 cent at A4): the mean of each
  // stretch.
  auto mean_cents = [](const std::vector<std::pair<double, double>> &v) {
    double sum = 0;
    for (const auto &x : v) sum += x.second;
    return sum / static_cast<double>(v.size());
  };
  INFO("before the wheel " << mean_cents(before) << " cents, after it " << mean_cents(after) << " cents");
  CHECK(std::fabs(mean_cents(before)) < 0.1);
  CHECK(std::fabs(mean_cents(after)) < 0.1);
  double lo = 1e9, hi = -1e9;
  for (const auto &d : during) lo = std::min(lo, d.second), hi = std::max(hi, d.second);
  // Rate: upward zero crossings, first to last, each after the pitch was 10 cents below (an
  // edge's jitter near zero must not count twice).
  std::vector<double> ups;
  bool armed = false;
  for (const auto &d : during) {
    if (d.second < -10) armed = true;
    if (armed && d.second >= 0) ups.push_back(d.first), armed = false;
  }
  REQUIRE(ups.size() >= 5);
  const double rate_hz = static_cast<double>(ups.size() - 1) / (ups.back() - ups.front());
  const double depth = (hi - lo) / 2;
  std::printf("vibrato: depth %.1f cents (peak %+.1f, trough %+.1f), rate %.3f Hz over %zu cycles\n", depth, hi, lo,
              rate_hz, ups.size() - 1);
  CHECK(std::fabs(depth / 50.0 - 1) < 0.1);
  CHECK(std::fabs(rate_hz / 5.5 - 1) < 0.1);
}

TEST_CASE("live: glide (CC65, CC5) slides a motor into its next note for the set time and lands on pitch",
          "[e2e][live][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string trace_path = e2e::scratch("glide.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  stepchoir::ChildProcess live(
      {STEPCHOIR_BIN, "live", "--midi-api", "jack", "--midi", Sender::kPort, "--port", vb.pty(), "--quiet"}, true);
  std::string line;
  REQUIRE(live.read_line(&line, 30000));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  keys.send(stepchoir::control_change(0, stepchoir::kCcPortamento, 127));
  keys.send(stepchoir::control_change(0, stepchoir::kCcPortamentoTime, 20));  // 320 ms
  keys.send(stepchoir::note_on(0, 57, 100));  // A3
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  keys.send(stepchoir::note_off(0, 57));
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  keys.send(stepchoir::note_on(0, 69, 100));  // A4: the same motor slides up an octave
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  keys.send(stepchoir::note_off(0, 69));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  size_t motor = 0;
  const tr::Trace t = finish(live, vb, trace_path, &motor);
  const auto cents = cents_by_edge(t, motor);  // against A4
  // The second note: the edges after the silence between the two.
  const auto &s = t.motor[motor].steps;
  double second_start = -1;
  for (size_t i = 1; i < s.size(); ++i)
    if (t.real_seconds(s[i].rise_cycle) - t.real_seconds(s[i - 1].rise_cycle) > 0.02)
      second_start = t.real_seconds(s[i].rise_cycle);
  REQUIRE(second_start > 0);
  double landed = -1;
  std::vector<double> last;
  for (const auto &[time, c] : cents) {
    if (time < second_start) continue;
    if (landed < 0 && std::fabs(c) < 5.0) landed = time;
    if (time > second_start + 0.5) last.push_back(c);
  }
  REQUIRE(landed > 0);
  REQUIRE(!last.empty());
  double mean = 0;
  for (double c : last) mean += c;
  mean /= static_cast<double>(last.size());
  const double first = std::upper_bound(cents.begin(), cents.end(), std::make_pair(second_start, 1e9))->second;
  std::printf("glide: starts %+.1f cents from A4, within 5 cents after %.1f ms, then %+.3f cents\n", first,
              (landed - second_start) * 1e3, mean);
  CHECK(std::fabs(first + 1200) < 40);  // from A3, one tick's step at most
  CHECK(std::fabs((landed - second_start) / 0.320 - 1) < 0.1);
  CHECK(std::fabs(mean) < 0.1);  // on pitch
}

TEST_CASE("live: velocity doubling: a loud note sounds in unison on two or three free motors and stops on all",
          "[e2e][live][pacing]") {
  LiveRig rig("velocity", "[velocity]\ndouble_at = 100\ntriple_at = 120\n");
  INFO("stepchoir live said: " << rig.said);
  REQUIRE(rig.said.find("-> 4 motors") != std::string::npos);
  Sender &keys = rig.keys;
  auto wait_ms = [](int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); };
  // A key, the velocity it is struck at, the motors it must sound on, how long it is held (ms).
  struct Strike {
    uint8_t note, velocity;
    size_t motors;
    int held_ms;
  };
  // Alone on four free motors: soft, loud, louder; each its own pitch, each released before the
  // next. Then three keys held, and 100 ms later a loud fourth: the one free motor, no doubling.
  const std::vector<Strike> strikes = {{69, 64, 1, 500},  {71, 110, 2, 500}, {72, 127, 3, 500}, {60, 64, 1, 600},
                                       {64, 64, 1, 600},  {67, 64, 1, 600},  {74, 127, 1, 500}};
  for (size_t i = 0; i < 3; ++i) {
    keys.send(stepchoir::note_on(0, strikes[i].note, strikes[i].velocity));
    wait_ms(strikes[i].held_ms);
    keys.send(stepchoir::note_off(0, strikes[i].note));
    wait_ms(300);
  }
  for (size_t i = 3; i < 6; ++i) keys.send(stepchoir::note_on(0, strikes[i].note, strikes[i].velocity));
  wait_ms(100);
  keys.send(stepchoir::note_on(0, strikes[6].note, strikes[6].velocity));
  wait_ms(500);
  for (size_t i = 3; i < 7; ++i) keys.send(stepchoir::note_off(0, strikes[i].note));
  wait_ms(300);
  size_t busiest = 0;
  const tr::Trace t = finish(*rig.live, rig.vb, rig.trace_path, &busiest);

  const std::vector<e2e::Sounded> sounded = e2e::sounded_notes(t);
  for (const e2e::Sounded &n : sounded)
    UNSCOPED_INFO("motor " << n.motor << ": " << n.pitch << " from " << n.start_s << " s to " << n.end_s << " s");
  size_t expected_notes = 0;
  for (const Strike &s : strikes) {
    expected_notes += s.motors;
    std::vector<e2e::Sounded> on;
    for (const e2e::Sounded &n : sounded)
      if (std::fabs(n.pitch - s.note) < 0.5) on.push_back(n);
    INFO("note " << int(s.note) << " at velocity " << int(s.velocity));
    REQUIRE(on.size() == s.motors);  // one segment each, on as many motors
    double worst_cents = 0, first_start = 1e9, last_start = 0, first_end = 1e9, last_end = 0;
    std::string motors;
    for (const e2e::Sounded &n : on) {
      const double cents = (n.pitch - s.note) * 100.0;
      if (std::fabs(cents) > std::fabs(worst_cents)) worst_cents = cents;
      first_start = std::min(first_start, n.start_s), last_start = std::max(last_start, n.start_s);
      first_end = std::min(first_end, n.end_s), last_end = std::max(last_end, n.end_s);
      motors += (motors.empty() ? "" : ",") + std::to_string(n.motor);
      INFO("motor " << n.motor << ": " << cents << " cents, " << (n.end_s - n.start_s) * 1e3 << " ms");
      CHECK(std::fabs(cents) < 1.0);
      CHECK(std::fabs((n.end_s - n.start_s) * 1e3 - s.held_ms) < 150);  // sounded until its note-off
    }
    for (size_t i = 0; i < on.size(); ++i)
      for (size_t j = i + 1; j < on.size(); ++j) CHECK(on[i].motor != on[j].motor);
    CHECK(last_start - first_start < 0.05);  // in unison from the strike
    CHECK(last_end - first_end < 0.05);      // and silenced together by the note-off
    std::printf("velocity: note %d at velocity %3d on %zu motor(s) (%s), worst pitch error %+.4f cents, "
                "starts %.1f ms apart, ends %.1f ms apart\n",
                s.note, s.velocity, on.size(), motors.c_str(), worst_cents, (last_start - first_start) * 1e3,
                (last_end - first_end) * 1e3);
  }
  CHECK(sounded.size() == expected_notes);  // nothing else sounded
}

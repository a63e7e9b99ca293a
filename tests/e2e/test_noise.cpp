// test_noise.cpp: a noisy line (the virtual board corrupts, drops or duplicates host bytes).
// The CRC keeps every wrong frame out, so no wrong note ever plays; a host that sends what
// should be sounding again every few milliseconds restores what was lost; the board's
// counters show the damage.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "analysis.h"
#include "core/pitch.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "trace.h"

using namespace stepchoir;
namespace tr = sc::trace;

namespace {

const double kNoteSeconds = 0.04;     // board time per chord
const double kRefreshSeconds = 0.004;  // the host sends the chord again this often
const int kChords = 60;

// The chord number c: four different notes, a different chord each time.
std::vector<int> chord_notes(int c) { return {48 + c % 24, 55 + (c * 5) % 24, 62 + (c * 7) % 24, 69 + (c * 11) % 24}; }

// Two step intervals (ticks) belong to the same note: within twice the worst edge lateness the
// firmware shows with four motors and this traffic (2 x 12.5 us), and less than a semitone
// (6 %, 570 ticks or more at every period played here).
bool same_note(double a, double b) { return std::abs(a - b) < 400.0; }

// A mean of two or three step intervals (ticks) is a period: one late edge moves it by half
// or a third of its lateness at most.
bool near(double mean, double period) { return std::abs(mean - period) < 200.0; }

// The board clock through a clock request, or nothing when the request or its reply was hit
// by the noise (a short wait, shorter than a refresh or two).
std::optional<uint32_t> clock_now(Board &b, uint8_t seq) {
  b.send({sc::kMsgClockReq, seq});
  for (;;) {
    const auto r = b.wait_reply(sc::kMsgClock, 10);
    if (!r) return std::nullopt;
    if (r->size() >= 6 && (*r)[1] == seq) return sc::get_u32(&(*r)[2]);
  }
}

// Plays kChords chords on the Uno through a line with the given vboard noise options: no
// note other than those sent ever plays, and each chord plays by the end of its window unless
// an earlier one still does. Returns the board status.
Status play_through_noise(const std::string &name, const std::vector<std::string> &noise) {
  const std::string trace_path = e2e::scratch(name + ".csv");
  std::vector<std::string> args{"--board", "uno", "--seconds", "60", "--trace", trace_path, "--quiet"};
  args.insert(args.end(), noise.begin(), noise.end());
  e2e::StoppableVboard vb(args);
  Board b(open_link(vb.pty()));
  const Caps caps = b.hello();
  for (int i = 0; i < 3; ++i) {  // the noise may hit any frame: these are worth repeating
    b.send(e2e::watchdog_payload(0));  // a pause of the host must not silence the board
    b.send({sc::kMsgResetCounters});
  }

  std::vector<std::vector<uint32_t>> periods;
  std::vector<uint32_t> starts;
  uint8_t seq = 0x10;
  std::optional<uint32_t> first;
  while (!first) first = clock_now(b, seq++);
  uint32_t now = *first;
  for (int c = 0; c < kChords; ++c) {
    std::vector<sc::PeriodEntry> chord;
    std::vector<uint32_t> ps;
    for (uint8_t m = 0; m < caps.motor_count; ++m) {
      ps.push_back(hz_to_period_q8(note_hz(chord_notes(c)[m]), caps.f_cpu_hz));
      chord.push_back({m, ps.back()});
    }
    periods.push_back(ps);
    const auto payload = periods_payload(chord);
    starts.push_back(now);
    const uint32_t end = now + e2e::ticks_for(kNoteSeconds, caps.f_cpu_hz);
    while (static_cast<int32_t>(now - end) < 0) {  // the chord, again every kRefreshSeconds
      b.send(payload);
      const uint32_t next = now + e2e::ticks_for(kRefreshSeconds, caps.f_cpu_hz);
      while (static_cast<int32_t>(now - next) < 0)
        if (const auto t = clock_now(b, seq++)) now = *t;
    }
  }
  starts.push_back(now);
  std::optional<Status> st;
  for (int attempt = 0; attempt < 10 && !st; ++attempt) st = b.status(500);
  REQUIRE(st);
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  int late = 0, foreign = 0, checked = 0;
  for (uint8_t m = 0; m < caps.motor_count; ++m) {
    std::vector<double> sent;  // every period this motor was sent, in ticks
    for (const auto &ps : periods) sent.push_back(ps[m] / 256.0);
    // No wrong note: every run of three step intervals that agree (a note held for at least
    // three steps) has a mean that is one of the periods sent to this motor.
    const auto edges = tr::rise_cycles(t.motor[m].steps);
    for (size_t i = 3; i < edges.size(); ++i) {
      const double a = double(edges[i - 2] - edges[i - 3]), b = double(edges[i - 1] - edges[i - 2]),
                   c = double(edges[i] - edges[i - 1]);
      if (!same_note(a, b) || !same_note(b, c)) continue;
      const double mean = (a + b + c) / 3;
      bool known = false;
      for (double p : sent) known = known || near(mean, p);
      if (!known) {
        ++foreign;
        INFO(name << " motor " << int(m) << " steps " << mean << " ticks apart at cycle " << edges[i]);
        CHECK(known);
      }
    }
    // Lost chords restored: each chord plays by the end of its window (its last step interval
    // is its period), unless an earlier one still does (the new chord's frames all hit so far).
    for (int c = 0; c < kChords; ++c) {
      const auto w = tr::rise_cycles_in_window(t.motor[m].steps, starts[c], starts[c + 1]);
      if (w.size() < 2) continue;
      ++checked;
      const double last = double(w.back() - w[w.size() - 2]);
      auto is = [&](int k) { return same_note(last, sent[k]); };
      const bool now_right = is(c);
      bool still_before = false;
      for (int e = 0; e < c; ++e) still_before = still_before || is(e);
      INFO(name << " chord " << c << " motor " << int(m) << ": last step " << last << " ticks after the one before, sent "
                << sent[c]);
      CHECK((now_right || still_before));
      late += still_before && !now_right;
    }
  }
  std::printf("%s: %d chords on %u motors; %d windows still on an earlier chord; %d foreign notes; board frames ok "
              "%u bad %u, last error %u\n",
              name.c_str(), kChords, caps.motor_count, late, foreign, st->head.frames_ok, st->head.frames_bad,
              st->head.last_error);
  CHECK(checked == kChords * caps.motor_count);  // every window played (none silent)
  CHECK(late <= kChords * caps.motor_count / 10);  // most chords are restored within their window
  return *st;
}

}  // namespace

TEST_CASE("noise: uno with 1 % of host bytes corrupted plays no wrong note and restores lost chords", "[pacing]") {
  const Status st = play_through_noise("noise-corrupt-uno", {"--line-corrupt", "0.01", "--seed", "5"});
  CHECK(st.head.frames_bad > 0);  // the damage is counted
}

TEST_CASE("noise: uno with 1 % of host bytes dropped and 1 % duplicated plays no wrong note", "[pacing]") {
  const Status st =
      play_through_noise("noise-drop-dup-uno", {"--line-drop", "0.01", "--line-duplicate", "0.01", "--seed", "6"});
  CHECK(st.head.frames_bad > 0);
}

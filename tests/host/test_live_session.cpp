// test_live_session.cpp: a LiveSession writing to a fake link: notes become set-period frames,
// stop silences all, a slow or restarted link still ends up with what should sound, heartbeats,
// periodic refreshes and vibrato between events, the link budget, jam's song frames beside live
// notes, a board's announcement told from a hello's answer, and the threads' writes inside
// real-time scopes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <set>
#include <thread>
#include <vector>

#include "board/board.h"
#include "core/pitch.h"
#include "live/session.h"
#include "live_fakes.h"

using namespace stepchoir;
using namespace stepchoir::live_test;

namespace {

// A velocity below [velocity]'s default double_at (live/velocity.h): one motor a note.
constexpr uint8_t kSoft = 64;

const uint32_t kF = 16000000;
const int kNoRefresh = 3600 * 1000;  // ms: no state refresh while a test checks exact frames

}  // namespace

TEST_CASE("live: pool configuration spans the boards", "[live]") {
  const AllocatorConfig c = pool_config({{nullptr, 4, 16000000}, {nullptr, 5, 20000000}}, Policy::kMono);
  CHECK(c.motor_count == 9);
  CHECK(c.motors[3].f_cpu_hz == 16000000);
  CHECK(c.motors[4].f_cpu_hz == 20000000);
  CHECK(c.mono_channel[8] == 0);
  CHECK_THROWS_AS(pool_config({}, Policy::kPoly), std::invalid_argument);
  CHECK_THROWS_AS(pool_config({{nullptr, 30, kF}, {nullptr, 5, kF}}, Policy::kPoly), std::invalid_argument);
}

TEST_CASE("live: notes reach the link as set-period frames, and stop silences and stops all", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 4, kF}}, pool_config({{&link, 4, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  const uint32_t a4 = hz_to_period_q8(note_hz(69), kF);
  const uint32_t e5 = hz_to_period_q8(note_hz(76), kF);
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft, monotonic_us())));
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 76, kSoft, monotonic_us())));
  REQUIRE(eventually([&] { return entries_of(link.frames()).size() >= 2; }));
  CHECK(eventually([&] { return s.motor_note(0) == 69 && s.motor_note(1) == 76; }));
  REQUIRE(s.midi_queue().try_enqueue(note_off(0, 69, 0, monotonic_us())));
  REQUIRE(eventually([&] { return entries_of(link.frames()).size() >= 3; }));
  CHECK(eventually([&] { return s.motor_note(0) == -1; }));
  s.stop();
  const auto frames = link.frames();
  REQUIRE(frames.size() >= 2);
  CHECK(frames.front()[0] == sc::kMsgWatchdog);
  CHECK(sc::get_u16(&frames.front()[1]) == sc::kWatchdogDefaultMs);
  CHECK(frames.back()[0] == sc::kMsgStopAll);
  const auto entries = entries_of(frames);
  // Motor 1 is silenced by stop(); motors already silent get no entry (stop-all covers them).
  CHECK(periods_of(entries, 0) == std::vector<uint32_t>{a4, 0});
  CHECK(periods_of(entries, 1) == std::vector<uint32_t>{e5, 0});
  CHECK(periods_of(entries, 3).empty());
  CHECK(s.events() == 3);
  CHECK(s.latency().count() == 4);
  CHECK(s.board_stats(0).frames_sent.load() == frames.size());
}

TEST_CASE("live: the stats keep the latest note's callback stamp and when its write returned", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  const BoardStats &st = s.board_stats(0);
  CHECK(st.last_event_us.load() == 0);
  const uint64_t stamp = monotonic_us();
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft, stamp)));
  REQUIRE(eventually([&] { return st.last_event_us.load() == stamp && st.last_written_us.load() >= stamp; }));
  CHECK(st.last_written_us.load() <= monotonic_us());
  s.stop();
}

TEST_CASE("live: jam - song frames from another thread go out whole and in order, live notes on their motors",
          "[live]") {
  FakeLink link;
  const LiveBoard board{&link, 2, kF, {2, 3}};  // the keyboard plays motors 2 and 3
  LiveSession s({board}, pool_config({board}, Policy::kPoly), kNoRefresh);
  s.forward_replies(0);
  s.start();
  const int kSongFrames = 200;
  std::thread song([&] {  // the song player's thread
    for (int i = 0; i < kSongFrames; ++i) {
      std::vector<uint8_t> p{sc::kMsgAt, 0, 0, 0, 0};
      sc::put_u32(&p[1], static_cast<uint32_t>(i));
      const auto e = periods_payload({{0, static_cast<uint32_t>(1000 + i)}});
      p.insert(p.end(), e.begin(), e.end());
      const auto wire = frame(p);
      while (!s.send_song_frame(0, wire.data(), wire.size())) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  for (int i = 0; i < 20; ++i) {
    REQUIRE(s.midi_queue().try_enqueue(note_on(0, static_cast<uint8_t>(60 + i), 100, monotonic_us())));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    REQUIRE(s.midi_queue().try_enqueue(note_off(0, static_cast<uint8_t>(60 + i), 0, monotonic_us())));
  }
  song.join();
  uint8_t buf[16];
  CHECK(s.read_board_bytes(0, buf, sizeof buf, 10) == 0);  // the fake board says nothing
  REQUIRE(eventually([&] {
    size_t at = 0;
    for (const auto &f : link.frames()) at += f[0] == sc::kMsgAt;
    return at == kSongFrames;
  }));
  s.stop();
  uint32_t next = 0;
  for (const auto &f : link.frames()) {
    if (f[0] != sc::kMsgAt) continue;
    CHECK(sc::get_u32(&f[1]) == next++);  // whole and in order
  }
  const auto entries = entries_of(link.frames());
  size_t live = 0;
  for (const auto &e : entries) {
    CHECK((e.motor == 2 || e.motor == 3));  // the keyboard never touches the song's motors
    live += e.period_q8 != 0;
  }
  // Every key went out, unless its release came before the writer got to it (then the two
  // were folded into the silence: counted as coalesced).
  CHECK(live + s.board_stats(0).coalesced.load() >= 20);
  CHECK(live >= 10);
}

TEST_CASE("live: capabilities the board announced as it started are a restart, a hello's answer is not", "[live]") {
  FakeLink link;
  const LiveBoard board{&link, 2, kF, {2, 3}};  // the keyboard plays motors 2 and 3
  LiveSession s({board}, pool_config({board}, Policy::kPoly), kNoRefresh);
  s.forward_replies(0);
  s.start();
  const BoardStats &st = s.board_stats(0);
  const auto caps = [](uint8_t version, uint8_t flags) {
    std::vector<uint8_t> p(1 + sizeof(sc::CapsBody), 0);
    p[0] = sc::kMsgCaps;
    p[1] = version;
    p[1 + offsetof(sc::CapsBody, flags)] = flags;
    return frame(p);
  };
  uint8_t buf[64];
  // The board says its capabilities; true once the song player read them and the reader
  // decoded them (it heard a frame), and a moment later (the reader's flag follows).
  const auto board_says = [&](const std::vector<uint8_t> &wire) {
    const uint64_t heard = st.heard_us.load();
    link.board_says(wire);
    const bool read = eventually([&] { return s.read_board_bytes(0, buf, sizeof buf, 10) == static_cast<long>(wire.size()); });
    const bool decoded = eventually([&] { return st.heard_us.load() != heard; });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return read && decoded;
  };
  // Answers to hellos, however many and whenever they come: no restart. Nor from a board of
  // protocol version 2, which has no flags (the byte there is its name's first).
  REQUIRE(board_says(caps(sc::kProtocolVersion, 0)));
  REQUIRE(board_says(caps(sc::kProtocolVersion, 0)));
  REQUIRE(board_says(caps(2, sc::kCapsAnnounced)));
  CHECK_FALSE(st.restarted.load());
  // Announced: the board started again, whatever hello went before.
  REQUIRE(board_says(caps(sc::kProtocolVersion, sc::kCapsAnnounced)));
  CHECK(eventually([&] { return st.restarted.load(); }));
  // A link attached anew clears the flag.
  REQUIRE(s.detach_link(0));
  s.attach_link(0, &link);
  CHECK_FALSE(st.restarted.load());
  REQUIRE(board_says(caps(sc::kProtocolVersion, 0)));
  CHECK_FALSE(st.restarted.load());
  s.stop();
}

TEST_CASE("live: a slow link gets the latest states, every silence, and ends silent", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kChannel), kNoRefresh);
  s.start();
  const uint32_t c4 = hz_to_period_q8(note_hz(60), kF);
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 60, kSoft)));  // channel 0 -> motor 0
  REQUIRE(eventually([&] { return periods_of(entries_of(link.frames()), 0) == std::vector<uint32_t>{c4}; }));
  link.set_open(false);  // from here the writer blocks in its next write until every event is in
  const int kRepeats = 200;
  for (int i = 1; i <= kRepeats; ++i) {  // the note released and struck again 200 times, bending
    REQUIRE(s.midi_queue().try_enqueue(note_off(0, 60)));
    REQUIRE(s.midi_queue().try_enqueue(pitch_bend(0, static_cast<uint16_t>(8192 + 40 * i))));
    REQUIRE(s.midi_queue().try_enqueue(note_on(0, 60, kSoft)));
  }
  REQUIRE(s.midi_queue().try_enqueue(note_on(1, 64, kSoft)));  // channel 1 -> motor 1
  REQUIRE(eventually([&] { return s.events() == 3 * kRepeats + 2; }));
  link.set_open(true);
  const uint32_t last_bend = hz_to_period_q8(note_hz(60 + 2.0 * (40 * kRepeats) / 8192), kF);
  REQUIRE(eventually([&] {
    const auto e = entries_of(link.frames());
    return !periods_of(e, 1).empty() && periods_of(e, 0).back() == last_bend;
  }));
  const auto before_stop = periods_of(entries_of(link.frames()), 0);
  s.stop();
  const auto entries = entries_of(link.frames());
  // A handful of frames for 600 events: the states were coalesced.
  CHECK(link.frames().size() < 12);
  CHECK(s.board_stats(0).coalesced.load() > 0);
  // The note was struck again: a silence went out between the first note and the last.
  REQUIRE(before_stop.size() >= 3);
  CHECK(before_stop.front() == c4);
  CHECK(std::find(before_stop.begin(), before_stop.end(), 0u) != before_stop.end());
  // Never two notes in a row without the silence between them, and silent at the end.
  const auto m0 = periods_of(entries, 0);
  for (size_t i = 1; i < m0.size(); ++i) CHECK((m0[i] == 0 || m0[i - 1] == 0));
  CHECK(m0.back() == 0);
  CHECK(periods_of(entries, 1) == std::vector<uint32_t>{hz_to_period_q8(note_hz(64), kF), 0});
}

TEST_CASE("live: the engine writes an idle link's frames itself, in order, and a link that would wait gets them from the writer", "[live]") {
  FakeLink link(true);
  LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kChannel), kNoRefresh);
  s.start();
  const uint32_t c4 = hz_to_period_q8(note_hz(60), kF), e4 = hz_to_period_q8(note_hz(64), kF),
                 d4 = hz_to_period_q8(note_hz(62), kF);
  auto motor = [&](uint8_t m) { return periods_of(entries_of(link.frames()), m); };
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 60, kSoft)));  // channel n -> motor n
  REQUIRE(eventually([&] { return motor(0) == std::vector<uint32_t>{c4}; }));
  REQUIRE(s.midi_queue().try_enqueue(note_on(1, 64, kSoft)));
  REQUIRE(eventually([&] { return motor(1) == std::vector<uint32_t>{e4}; }));
  REQUIRE(s.midi_queue().try_enqueue(note_off(0, 60)));
  REQUIRE(eventually([&] { return motor(0) == std::vector<uint32_t>{c4, 0}; }));
  CHECK(s.board_stats(0).direct_frames.load() >= 1);  // the writer takes one only while busy
  // The link would make a writer wait: the engine writes nothing and never blocks; the writer
  // gets the updates, in order, once the link takes bytes again.
  link.set_open(false);
  const uint64_t direct = s.board_stats(0).direct_frames.load();
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 62, kSoft)));
  REQUIRE(s.midi_queue().try_enqueue(note_off(1, 64)));
  REQUIRE(eventually([&] { return s.events() == 5; }));
  link.set_open(true);
  REQUIRE(eventually([&] { return motor(0).back() == d4 && motor(1).back() == 0; }));
  CHECK(s.board_stats(0).direct_frames.load() == direct);
  s.stop();
  CHECK(motor(0) == std::vector<uint32_t>{c4, 0, d4, 0});
  CHECK(motor(1) == std::vector<uint32_t>{e4, 0});
}

TEST_CASE("live: heartbeats keep the watchdog fed while nothing plays", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 1, kF}}, pool_config({{&link, 1, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  // Liveness only: at least two heartbeats come, however slow the machine.
  REQUIRE(eventually([&] { return s.board_stats(0).heartbeats.load() >= 2; }));
  s.stop();
  size_t heartbeats = 0;
  for (const auto &f : link.frames()) heartbeats += f.size() == 1 && f[0] == sc::kMsgHeartbeat;
  CHECK(heartbeats >= 2);
}

TEST_CASE("live: after a board restart the coalescer restores what should sound", "[live]") {
  Coalescer c;
  sc::PeriodEntry out[Coalescer::kMaxMotors];
  c.add({0, 1000000, 1});
  c.add({1, 1100000, 1});
  REQUIRE(c.take_latest(out, nullptr) == 2);
  c.add({1, 0, 2});
  REQUIRE(c.take_latest(out, nullptr) == 1);  // motor 1 silent on the old board
  c.add({2, 1200000, 3});                      // not sent yet when the board went away
  c.board_restarted();
  REQUIRE(c.take_latest(out, nullptr) == 2);
  CHECK(out[0].motor == 0);
  CHECK(out[0].period_q8 == 1000000);
  CHECK(out[1].motor == 2);
  CHECK(out[1].period_q8 == 1200000);
  CHECK_FALSE(c.pending());
}

TEST_CASE("live: a new link gets the watchdog and the held notes, the old one nothing more", "[live]") {
  FakeLink first, second;
  LiveSession s({{&first, 2, kF}}, pool_config({{&first, 2, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  const uint32_t a4 = hz_to_period_q8(note_hz(69), kF);
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft)));
  REQUIRE(eventually([&] { return periods_of(entries_of(first.frames()), 0) == std::vector<uint32_t>{a4}; }));
  REQUIRE(s.detach_link(0));
  const size_t first_frames = first.frames().size();
  const uint32_t e5 = hz_to_period_q8(note_hz(76), kF);
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 76, kSoft)));  // played while no board is there
  REQUIRE(eventually([&] { return s.events() == 2; }));
  s.attach_link(0, &second);
  REQUIRE(eventually([&] { return entries_of(second.frames()).size() >= 2; }));
  s.stop();
  CHECK(first.frames().size() == first_frames);
  const auto frames = second.frames();
  REQUIRE_FALSE(frames.empty());
  CHECK(frames.front()[0] == sc::kMsgWatchdog);
  const auto entries = entries_of(frames);
  CHECK(periods_of(entries, 0) == std::vector<uint32_t>{a4, 0});
  CHECK(periods_of(entries, 1) == std::vector<uint32_t>{e5, 0});
  CHECK(frames.back()[0] == sc::kMsgStopAll);
}

TEST_CASE("live: the writer keeps to the link budget when events come faster", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 4, kF}}, pool_config({{&link, 4, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 2000; ++i) {  // 2000 notes, each on then off, as fast as the queue takes them
    const uint8_t n = static_cast<uint8_t>(40 + i % 40);
    while (!s.midi_queue().try_enqueue(note_on(0, n, kSoft))) std::this_thread::yield();
    while (!s.midi_queue().try_enqueue(note_off(0, n))) std::this_thread::yield();
  }
  REQUIRE(eventually([&] { return s.events() == 4000; }));
  s.stop();
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Upper bound on the bytes written: one burst plus the rate over the time it took, plus the
  // frame that may go over, the final silences and the stop-all (two 20-byte frames, 5 bytes).
  const double allowed = double(LinkBudget::kBurstBytes) + double(LinkBudget::kBytesPerSecond) * elapsed_s + 20 + 20 + 5;
  CHECK(static_cast<double>(s.board_stats(0).bytes_sent.load()) <= allowed);
  for (uint8_t m = 0; m < 4; ++m) {
    const auto p = periods_of(entries_of(link.frames()), m);
    if (!p.empty()) CHECK(p.back() == 0);
  }
}

TEST_CASE("live: the mod wheel's vibrato reaches the link between events, and is no latency sample", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kPoly), kNoRefresh);
  s.start();
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft, monotonic_us())));
  REQUIRE(s.midi_queue().try_enqueue(control_change(0, kCcModWheel, 127, monotonic_us())));
  // With no further event the engine keeps moving the pitch: many different periods on motor 0.
  REQUIRE(eventually([&] {
    const auto m0 = periods_of(entries_of(link.frames()), 0);
    return std::set<uint32_t>(m0.begin(), m0.end()).size() >= 10;
  }));
  s.stop();
  INFO("latency samples: " << s.latency().count());
  CHECK(s.latency().count() <= 3);  // the note-on, the wheel, stop()'s silence: no tick
}

TEST_CASE("live: every motor's state is sent again periodically", "[live]") {
  FakeLink link;
  LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kPoly), 20);
  s.start();
  const uint32_t a4 = hz_to_period_q8(note_hz(69), kF);
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft)));
  // The held note and the silent motor come again and again; the refreshes are no latency sample.
  REQUIRE(eventually([&] {
    const auto e = entries_of(link.frames());
    const auto m0 = periods_of(e, 0);
    return std::count(m0.begin(), m0.end(), a4) >= 2 && periods_of(e, 1).size() >= 2;
  }));
  s.stop();
  const auto e = entries_of(link.frames());
  // Motor 0: silence (refreshed before the note came), the note (refreshed), silence (stop()).
  const auto m0 = periods_of(e, 0);
  const auto first_note = std::find(m0.begin(), m0.end(), a4);
  REQUIRE(first_note != m0.end());
  const auto after_note = std::find(first_note, m0.end(), 0u);
  CHECK(std::count(m0.begin(), first_note, 0u) == first_note - m0.begin());
  CHECK(std::count(first_note, after_note, a4) >= 2);  // the note and at least one refresh of it
  CHECK(std::count(first_note, after_note, a4) == after_note - first_note);
  REQUIRE(after_note != m0.end());
  CHECK(std::count(after_note, m0.end(), 0u) == m0.end() - after_note);
  for (uint32_t p : periods_of(e, 1)) CHECK(p == 0);
  INFO("latency samples: " << s.latency().count());
  CHECK(s.latency().count() >= 1);  // the note-on (stop()'s silence may fold into a refresh)
  CHECK(s.latency().count() <= 2);
}

TEST_CASE("live: the engine and writer threads write only from inside real-time scopes", "[live]") {
  for (const bool direct : {true, false}) {
    FakeLink link(direct);
    LiveSession s({{&link, 2, kF}}, pool_config({{&link, 2, kF}}, Policy::kChannel), 50);
    s.start();
    REQUIRE(s.midi_queue().try_enqueue(note_on(0, 60, kSoft)));
    REQUIRE(s.midi_queue().try_enqueue(note_on(1, 64, kSoft)));
    REQUIRE(eventually([&] { return s.events() == 2; }));
    std::this_thread::sleep_for(std::chrono::milliseconds(120));  // refreshes and a heartbeat
    s.stop();
    const auto writes = link.thread_writes();
    CHECK(writes.first >= 3);
    CHECK(writes.second == 0);
  }
}

TEST_CASE("live: jam - a live note goes out ahead of song frames already waiting", "[live]") {
  FakeLink link;
  const LiveBoard board{&link, 2, kF, {2, 3}};
  LiveSession s({board}, pool_config({board}, Policy::kPoly), kNoRefresh);
  s.start();
  // 60 song frames queued at once: the writer sends them as the link budget allows (one every
  // millisecond or so), keeping half a burst free.
  for (int i = 0; i < 60; ++i) {
    std::vector<uint8_t> p{sc::kMsgAt, 0, 0, 0, 0};
    sc::put_u32(&p[1], static_cast<uint32_t>(i));
    const auto e = periods_payload({{0, static_cast<uint32_t>(1000 + i)}});
    p.insert(p.end(), e.begin(), e.end());
    const auto wire = frame(p);
    REQUIRE(s.send_song_frame(0, wire.data(), wire.size()));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  REQUIRE(s.midi_queue().try_enqueue(note_on(0, 69, kSoft, monotonic_us())));
  REQUIRE(eventually([&] {
    size_t at = 0;
    for (const auto &f : link.frames()) at += f[0] == sc::kMsgAt;
    return at == 60;
  }));
  s.stop();
  // Where the live note went out among the song frames: well before the last of them.
  size_t song_before = 0;
  bool live_seen = false;
  for (const auto &f : link.frames()) {
    if ((f[0] & sc::kSetPeriodFlag) && !live_seen) live_seen = true;
    if (f[0] == sc::kMsgAt && !live_seen) ++song_before;
  }
  REQUIRE(live_seen);
  CHECK(song_before < 45);  // of 60: without the priority every one of them goes first
}

TEST_CASE("live: jam - a board attached again drops the song motors' timed entries before a song frame",
          "[live]") {
  FakeLink first, second;
  const LiveBoard board{&first, 2, kF, {2, 3}};  // the keyboard plays motors 2 and 3
  LiveSession s({board}, pool_config({board}, Policy::kPoly), kNoRefresh);
  s.set_song_motors(0, 0x03);  // a song plays motors 0 and 1
  s.start();
  REQUIRE(s.detach_link(0));  // the board restarted: entries it holds are on its old clock
  s.attach_link(0, &second);
  std::vector<uint8_t> at{sc::kMsgAt, 0, 0, 0, 0};
  const auto e = periods_payload({{0, 1000}});
  at.insert(at.end(), e.begin(), e.end());
  const auto wire = frame(at);
  REQUIRE(s.send_song_frame(0, wire.data(), wire.size()));
  REQUIRE(eventually([&] {
    const auto f = second.frames();
    return std::any_of(f.begin(), f.end(), [](const auto &p) { return p[0] == sc::kMsgAt; });
  }));
  s.stop();
  const auto frames = second.frames();
  REQUIRE(frames.size() >= 3);
  CHECK(frames[0][0] == sc::kMsgWatchdog);
  CHECK(frames[1] == std::vector<uint8_t>{sc::kMsgSilence, 0x03});
  CHECK(std::count_if(frames.begin(), frames.end(), [](const auto &p) { return p[0] == sc::kMsgSilence; }) == 1);
}

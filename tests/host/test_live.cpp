// test_live.cpp: the live path's parts alone, without a MIDI system, a board or the engine's
// threads: message parsing, the MIDI callback's queueing, the Coalescer, the latency histogram,
// the link budget and the real-time allocation guard (a LiveSession on a fake link:
// test_live_session.cpp).
#include <catch2/catch.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>

#include "live/coalescer.h"
#include "live/jack_midi_input.h"
#include "live/latency_histogram.h"
#include "live/link_budget.h"
#include "live/midi_in.h"
#include "live/rt_guard.h"

using namespace stepchoir;

TEST_CASE("live: raw MIDI messages become events, others are refused", "[live]") {
  MidiEvent e{};
  const unsigned char on[] = {0x93, 60, 100};
  REQUIRE(parse_midi_message(on, 3, 42, &e));
  CHECK(e.status == 0x93);
  CHECK(e.data1 == 60);
  CHECK(e.data2 == 100);
  CHECK(e.timestamp_us == 42);
  const unsigned char pc[] = {0xC0, 5};
  REQUIRE(parse_midi_message(pc, 2, 0, &e));
  CHECK(e.data2 == 0);
  const unsigned char bend[] = {0xE1, 0x7F, 0x40};
  REQUIRE(parse_midi_message(bend, 3, 0, &e));
  CHECK(e.data1 == 0x7F);
  const unsigned char short_on[] = {0x90, 60};
  CHECK_FALSE(parse_midi_message(short_on, 2, 0, &e));
  const unsigned char clock[] = {0xF8};
  CHECK_FALSE(parse_midi_message(clock, 1, 0, &e));
  const unsigned char sysex[] = {0xF0, 1, 2, 0xF7};
  CHECK_FALSE(parse_midi_message(sysex, 4, 0, &e));
  const unsigned char data_only[] = {0x40, 0x40};
  CHECK_FALSE(parse_midi_message(data_only, 2, 0, &e));
  CHECK_FALSE(parse_midi_message(on, 0, 0, &e));
}

TEST_CASE("live: a JACK MIDI event is used only when its bytes lie inside the port buffer", "[live]") {
  // A port buffer as JACK hands it over; an event read from it points into it (a short event's
  // bytes are kept inline there). One read while an overrunning cycle rewrote the buffer can
  // point anywhere, or be longer than any message the live path takes.
  alignas(8) unsigned char memory[288] = {};
  unsigned char *const buffer = memory + 16;  // the port buffer: 256 bytes
  const size_t bytes = 256;
  jack_midi_event_t e{};
  e.buffer = buffer + 40;
  e.size = 3;
  CHECK(jack_event_usable(e, buffer, bytes));
  e.size = 1;  // a clock tick
  CHECK(jack_event_usable(e, buffer, bytes));
  e.buffer = buffer + bytes - 3;
  e.size = 3;
  CHECK(jack_event_usable(e, buffer, bytes));  // its last byte the buffer's last
  e.buffer = buffer + bytes - 2;
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));  // runs past the end
  e.buffer = buffer - 1;
  e.size = 1;
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));  // before it
  unsigned char elsewhere[3] = {0x90, 60, 100};
  e.buffer = elsewhere;
  e.size = 3;
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));
  e.buffer = nullptr;
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));
  e.buffer = buffer + 40;
  e.size = 0;
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));
  e.size = kJackMidiMaxBytes + 1;  // a sysex, or a garbage length
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));
  e.size = ~size_t(0);  // a length that wraps the pointer
  CHECK_FALSE(jack_event_usable(e, buffer, bytes));
}

TEST_CASE("live: the coalescer sends the latest state per motor", "[live]") {
  Coalescer c;
  sc::PeriodEntry out[Coalescer::kMaxMotors];
  uint64_t us[Coalescer::kMaxMotors];
  CHECK_FALSE(c.pending());
  c.add({0, 1000000, 1});
  c.add({0, 1100000, 2});  // a bend before the first went out
  c.add({2, 900000, 3});
  REQUIRE(c.pending());
  CHECK(c.take_silences(out, us) == 0);
  REQUIRE(c.take_latest(out, us) == 2);
  CHECK(out[0].motor == 0);
  CHECK(out[0].period_q8 == 1100000);
  CHECK(us[0] == 2);
  CHECK(out[1].motor == 2);
  CHECK(out[1].period_q8 == 900000);
  CHECK(c.coalesced() == 1);
  CHECK_FALSE(c.pending());
}

TEST_CASE("live: the coalescer never drops a silence", "[live]") {
  Coalescer c;
  sc::PeriodEntry out[Coalescer::kMaxMotors];
  uint64_t us[Coalescer::kMaxMotors];
  c.add({1, 1000000, 1});
  REQUIRE(c.take_latest(out, us) == 1);  // the note is on the wire
  SECTION("note off, then the same note again: silence first, then the note") {
    c.add({1, 0, 2});
    c.add({1, 1000000, 3});
    REQUIRE(c.take_silences(out, us) == 1);
    CHECK(out[0].motor == 1);
    CHECK(out[0].period_q8 == 0);
    CHECK(us[0] == 2);
    REQUIRE(c.take_latest(out, us) == 1);
    CHECK(out[0].period_q8 == 1000000);
    CHECK(us[0] == 3);
  }
  SECTION("off, on, off: one silence") {
    c.add({1, 0, 2});
    c.add({1, 1200000, 3});
    c.add({1, 0, 4});
    CHECK(c.take_silences(out, us) == 0);
    REQUIRE(c.take_latest(out, us) == 1);
    CHECK(out[0].period_q8 == 0);
    CHECK(us[0] == 4);
  }
  SECTION("without take_silences, take_latest still sends the silence first") {
    c.add({1, 0, 2});
    c.add({1, 1200000, 3});
    REQUIRE(c.take_latest(out, us) == 1);
    CHECK(out[0].period_q8 == 0);
    REQUIRE(c.take_latest(out, us) == 1);
    CHECK(out[0].period_q8 == 1200000);
  }
  SECTION("a note that never went out and its silence cancel") {
    c.add({3, 1300000, 2});
    c.add({3, 0, 3});
    CHECK(c.take_silences(out, us) == 0);
    CHECK(c.take_latest(out, us) == 0);
    CHECK_FALSE(c.pending());
  }
}

TEST_CASE("live: latency histogram percentiles", "[live]") {
  LatencyHistogram h;
  CHECK(h.percentile(0.5) == 0);
  for (uint64_t us = 1; us <= 100; ++us) h.record(us);
  h.record(50000);  // beyond the last bin: counted there, max keeps it
  CHECK(h.count() == 101);
  CHECK(h.percentile(0.5) == 51);
  CHECK(h.percentile(0.99) == 100);
  CHECK(h.percentile(1.0) == LatencyHistogram::kBins - 1);
  CHECK(h.max_us() == 50000);
}

TEST_CASE("live: the link budget allows a burst, then the average rate", "[live]") {
  LinkBudget b;
  b.refill(1000000);
  REQUIRE(b.can_send());
  CHECK(b.wait_us() == 0);
  b.spend(static_cast<size_t>(LinkBudget::kBurstBytes) + 20);  // a burst, then a four-note frame over
  CHECK_FALSE(b.can_send());
  const uint64_t wait = b.wait_us();
  CHECK(wait == static_cast<uint64_t>((20 * 1000000 + LinkBudget::kBytesPerSecond - 1) / LinkBudget::kBytesPerSecond));
  b.refill(1000000 + wait - 1);
  CHECK_FALSE(b.can_send());
  b.refill(1000000 + wait);
  CHECK(b.can_send());
  b.refill(1000000 + 60 * 1000000ull);  // a minute idle: no more than one burst saved up
  b.spend(static_cast<size_t>(LinkBudget::kBurstBytes));
  CHECK(b.can_send());
  b.spend(1);
  CHECK_FALSE(b.can_send());
}

TEST_CASE("live: the MIDI callback's work queues stamped events and counts what does not fit", "[live]") {
  MidiQueue queue(2);
  auto in = MidiIn::without_port(queue);
  const uint64_t before_us = monotonic_us();
  const unsigned char on[] = {0x91, 64, 90};
  const unsigned char clock[] = {0xF8};
  in->on_message(on, sizeof on);     // in a Debug build this aborts if it allocates (rt_guard.h)
  in->on_message(clock, sizeof clock);
  MidiEvent e{};
  REQUIRE(queue.try_dequeue(e));
  CHECK(e.status == 0x91);
  CHECK(e.data1 == 64);
  CHECK(e.timestamp_us >= before_us);
  CHECK_FALSE(queue.try_dequeue(e));  // the clock byte is no channel message
  for (int i = 0; i < 20; ++i) in->on_message(on, sizeof on);
  CHECK(in->received() + in->dropped() == 21);
  CHECK(in->dropped() > 0);
}

TEST_CASE("live: an allocation inside real-time code aborts exactly when the build has the guard", "[live]") {
  // Debug builds have the guard (rt_guard_enabled); others must not abort.
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    RtScope rt;
    volatile int *leak = new int(1);
    (void)leak;
    _exit(0);
  }
  int status = 0;
  REQUIRE(waitpid(child, &status, 0) == child);
  if (rt_guard_enabled()) {
    CHECK(WIFSIGNALED(status));
    CHECK(WTERMSIG(status) == SIGABRT);
  } else {
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
  }
  // Scopes nest, and an exemption suspends them all for its block.
  CHECK_FALSE(in_rt_scope());
  {
    RtScope a;
    RtScope b;
    CHECK(in_rt_scope());
    {
      RtExempt e;
      CHECK_FALSE(in_rt_scope());
    }
    CHECK(in_rt_scope());
  }
  CHECK_FALSE(in_rt_scope());
}

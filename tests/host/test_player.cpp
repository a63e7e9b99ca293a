// test_player.cpp: the song player's clock fit (offset, rate, wrap, outliers, a reset, bridges).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "bridge_model.h"
#include "player/clock_sync.h"
#include "player/start_gate.h"

using namespace stepchoir;

namespace {

// A simulated board clock: ticks at host time t_us for a crystal ppm off, starting at start.
struct FakeBoard {
  double ppm = 0, start_ticks = 0;
  double stall_at_us = 1e300, stall_us = 0;  // its clock stands still this long from then on
  uint32_t ticks_at(double t_us) const {
    if (t_us > stall_at_us) t_us = std::max(stall_at_us, t_us - stall_us);
    const double t = start_ticks + t_us * 16.0 * (1 + ppm / 1e6);
    return static_cast<uint32_t>(static_cast<uint64_t>(std::llround(t)) & 0xffffffffu);
  }
};

// Feeds n round trips every step_us, with round trips of rtt_us plus random extra delay on
// the way back (up to jitter_us); the board stamps at the true midpoint of the fixed part.
void feed(ClockSync &sync, const FakeBoard &b, double from_us, int n, double step_us, double rtt_us, double jitter_us,
          std::mt19937 &rng) {
  std::uniform_real_distribution<double> extra(0, jitter_us);
  for (int i = 0; i < n; ++i) {
    const double send = from_us + i * step_us;
    const double stamp = send + rtt_us / 2;
    const double recv = send + rtt_us + extra(rng);
    REQUIRE(sync.add(static_cast<uint64_t>(send), static_cast<uint64_t>(recv), b.ticks_at(stamp)));
  }
}

}  // namespace

TEST_CASE("clock: the fit finds a crystal's error and the board's time through host jitter", "[player]") {
  std::mt19937 rng(7);
  for (double ppm : {-5000.0, -120.0, 0.0, 5000.0}) {
    ClockSync sync(16e6);
    const FakeBoard b{ppm, 123456789};
    feed(sync, b, 1e6, 300, 10000, 300, 800, rng);  // 3 s of round trips, up to 0.8 ms extra
    CHECK(sync.ppm() == Approx(ppm).margin(30.0));  // 30 ppm = 0.05 cent
    // The board's time when a request sent now, and one a lead ahead, reaches it (the way out
    // is half the fixed round trip here), within 100 us: the replies' extra delay does not
    // move it.
    for (double at : {4e6, 4.3e6}) {
      const double want = 123456789 + (at + 150) * 16.0 * (1 + ppm / 1e6);
      CHECK(std::fabs(sync.ticks_at(at) - want) / 16.0 < 100.0);
      CHECK(sync.host_us_at(want) == Approx(at).margin(100.0));
    }
  }
}

TEST_CASE("clock: before a second of samples the rate stays nominal, and the offset is fitted", "[player]") {
  std::mt19937 rng(1);
  ClockSync sync(16e6);
  const FakeBoard b{3000, 5};
  feed(sync, b, 0, 20, 10000, 200, 0, rng);  // 0.2 s
  CHECK(sync.ticks_per_s() == 16e6);
  CHECK(std::fabs(sync.ticks_at(0.1e6) - (5 + 0.1e6 * 16 * 1.003)) / 16 < 400);  // 3000 ppm of 0.1 s
}

TEST_CASE("clock: the 32-bit counter wraps and the fit carries on", "[player]") {
  std::mt19937 rng(3);
  ClockSync sync(16e6);
  const FakeBoard b{0, 4294967296.0 - 16e6};  // wraps one second in
  feed(sync, b, 0, 300, 10000, 200, 100, rng);
  const double want = 4294967296.0 - 16e6 + (3e6 + 100) * 16;  // unwrapped, past the wrap
  CHECK(std::fabs(sync.ticks_at(3e6) - want) / 16 < 40);
  CHECK(sync.ppm() == Approx(0).margin(30));
}

TEST_CASE("clock: a board that falls behind for a moment is followed, not taken for a new one", "[player]") {
  std::mt19937 rng(3);
  ClockSync sync(16e6);
  FakeBoard b{0, 1000};
  b.stall_at_us = 1e6;  // its clock stands still for 100 ms (a stalled simulation)
  b.stall_us = 1e5;
  feed(sync, b, 0, 700, 10000, 200, 0, rng);  // every sample accepted (feed REQUIREs it)
  CHECK(std::fabs(sync.ticks_at(7e6) - b.ticks_at(7e6 + 100)) / 16 < 100);
}

TEST_CASE("clock: one odd sample is ignored, two in a row mean a new board", "[player]") {
  std::mt19937 rng(3);
  ClockSync sync(16e6);
  const FakeBoard b{0, 1000};
  feed(sync, b, 0, 50, 10000, 200, 0, rng);
  const double before = sync.ticks_at(0.6e6);
  CHECK(sync.add(500000, 500200, 77));  // far off: ignored
  CHECK(sync.ticks_at(0.6e6) == Approx(before));
  CHECK(sync.add(510000, 510200, b.ticks_at(510100)));  // back on the line: fine
  CHECK(sync.add(520000, 520200, 77));
  CHECK_FALSE(sync.add(530000, 530200, 99));  // twice: the board restarted
  sync.reset();
  CHECK_FALSE(sync.ready());
  CHECK(sync.add(540000, 540200, 99));
}

TEST_CASE("clock: late replies, and a host held up between its stamp and its write, do not pull the fit",
          "[player]") {
  std::mt19937 rng(5);
  ClockSync sync(16e6);
  const FakeBoard b{0, 0};
  // Every third reply comes 5 ms late (a loaded host reading); every tenth request went out
  // 5 ms after its stamp (a host held up before writing): the fit keeps to the others.
  for (int i = 0; i < 300; ++i) {
    const double send = i * 10000.0;
    const double out = send + (i % 10 == 1 ? 5000 : 0);
    const double recv = out + 200 + (i % 3 == 0 ? 5000 : 0);
    REQUIRE(sync.add(static_cast<uint64_t>(send), static_cast<uint64_t>(recv), b.ticks_at(out + 100)));
  }
  CHECK(std::fabs(sync.ticks_at(3e6) - (3e6 + 100) * 16) / 16 < 5);
  CHECK(sync.residual_us() < 5);
}


TEST_CASE("clock: through a 16U2 bridge's 1 ms frames and 4 ms batches the rate converges as the song goes on",
          "[player]") {
  for (double ppm : {-5000.0, 0.0, 2500.0, 5000.0}) {
    ClockSync sync(16e6);
    BridgeModel link{ppm};
    double worst_after_2s = 0, worst_after_10s = 0;
    for (int i = 0; i < 1500; ++i) {  // 30 s at 50 round trips a second (the player makes 100)
      const double t = 1e6 + i * 20000.0 + (i % 7) * 131.0;
      REQUIRE(link.round_trip(sync, t));
      const double err = std::fabs(cents_of_ppm(sync.ppm() - ppm));
      if (i >= 150) worst_after_2s = std::max(worst_after_2s, err);  // 1 s of sync, then 2 s of song
      if (i >= 550) worst_after_10s = std::max(worst_after_10s, err);
    }
    INFO("crystal " << ppm << " ppm: the rate's worst error " << worst_after_2s << " cent from 3 s on, "
                    << worst_after_10s << " cent from 11 s on");
    std::printf("clock, 16U2 link, crystal %+.0f ppm: worst %.4f cent from 3 s on, %.4f cent from 11 s on\n", ppm,
                worst_after_2s, worst_after_10s);
    CHECK(worst_after_2s < 0.5);
    CHECK(worst_after_10s < 0.1);
  }
}

TEST_CASE("clock: through a 16U2 bridge the board's time is the quickest way out's, whatever the frames' phase",
          "[player]") {
  // Two boards' notes line up only if each fit lands on the same point of its link: the
  // request that catches its USB frame at once (no wait), stamped as its bytes arrive. The
  // requests go out at the player's golden-ratio steps through each frame.
  for (double phase_us : {0.0, 370.0, 810.0}) {
    for (double ppm : {-1500.0, 2000.0}) {
      ClockSync sync(16e6);
      BridgeModel link{ppm};
      link.frame_phase_us = phase_us;
      double worst_us = 0, dither = 0;
      for (int i = 0; i < 1500; ++i) {  // 30 s at 50 round trips a second
        dither = std::fmod(dither + 0.6180339887, 1.0);
        const double t = 1e6 + i * 20000.0 + dither * 1000;
        REQUIRE(link.round_trip(sync, t));
        if (i < 150) continue;  // the first 3 s
        const double quickest_stamp_us = t + link.stamp_after_frame_us();
        const double est_us = (sync.ticks_at(t) - 7e8) / (16.0 * (1 + ppm / 1e6));
        worst_us = std::max(worst_us, std::fabs(est_us - quickest_stamp_us));
      }
      INFO("frames at phase " << phase_us << " us, crystal " << ppm << " ppm: worst " << worst_us << " us");
      std::printf("clock, 16U2 link, frames at %.0f us, crystal %+.0f ppm: the board's time within %.0f us\n",
                  phase_us, ppm, worst_us);
      CHECK(worst_us < 150);
    }
  }
}

TEST_CASE("clock: a board that falls 10 ms behind for a moment and catches up moves neither rate nor time",
          "[player]") {
  // A stalled simulation: its clock stops for 10 ms, then runs three times as fast until it
  // is back; a round trip in that while is short but its stamp is behind. Once in the first
  // second (before the rate), then every 1.3 s.
  for (double first_s : {0.6, 2.0}) {
    ClockSync sync(16e6);
    BridgeModel link{5000};
    link.lag_us = [first_s](double t_us) {
      const double s = t_us / 1e6 - first_s;
      if (s < 0) return 0.0;
      const double in = std::fmod(s, 1.3) * 1e6;  // us into this stall
      return in < 10000 ? in : std::max(0.0, 10000 - (in - 10000) * 2);
    };
    double worst_ppm = 0, worst_time_us = 0;
    for (int i = 0; i < 750; ++i) {
      const double t = i * 20000.0 + 7000;
      REQUIRE(link.round_trip(sync, t));
      if (i < 100) continue;  // 2 s
      worst_ppm = std::max(worst_ppm, std::fabs(sync.ppm() - 5000));
      const double want = 7e8 + (t + 20000) * 16 * 1.005;  // the board's time one sample on
      worst_time_us = std::max(worst_time_us, std::fabs(sync.ticks_at(t + 20000) - want) / 16);
    }
    INFO("first stall at " << first_s << " s: worst rate error " << worst_ppm << " ppm, time " << worst_time_us << " us");
    std::printf("clock, stalls from %.1f s: worst %.1f ppm, %.0f us\n", first_s, worst_ppm, worst_time_us);
    CHECK(cents_of_ppm(worst_ppm) < 0.5);
    CHECK(worst_time_us < 3000);  // the bridge's own one-sided delays: a constant part
  }
}

TEST_CASE("players: several boards take one start once every one is synced, and one that gave up holds none back",
          "[player]") {
  StartGate gate(3);
  CHECK(gate.ready(0, 1000) == 0);
  CHECK(gate.ready(2, 1500) == 0);
  CHECK(gate.ready(0, 1800) == 0);  // asking again keeps its first time
  CHECK(gate.ready(1, 2000) == 2000);
  CHECK(gate.ready(0, 2001) == 2000);  // the same start for every player
  CHECK(gate.ready(2, 2002) == 2000);
  StartGate lost(2);
  CHECK(lost.ready(0, 500) == 0);
  lost.leave(1);  // its board never answered
  CHECK(lost.ready(0, 600) == 500);
}

TEST_CASE("clock: the newest reply's board time is a time the board surely reached, unwrapped", "[player]") {
  ClockSync sync(16e6);
  CHECK(sync.newest_ticks() == 0);  // no reply yet
  sync.add(1000000, 1000100, 4294967000u);
  sync.add(1001000, 1001100, 4294967000u + 16000u);  // the 32-bit counter wrapped
  CHECK(sync.newest_ticks() == Approx(4294967000.0 + 16000.0));
  CHECK(sync.newest_ticks() > 4294967296.0);
}

TEST_CASE("clock: a prior rate (the same crystal measured before) holds from the first sample, weighed as samples come",
          "[player]") {
  const double ppm = 3000;
  SECTION("a right prior: the rate is right before a second of samples, and stays right") {
    ClockSync sync(16e6);
    sync.set_prior(16e6 * (1 + (ppm + 8) / 1e6), 10);  // remembered 8 ppm off
    CHECK(sync.has_rate());
    CHECK(sync.ppm() == Approx(ppm + 8));
    BridgeModel link{ppm};
    double worst = 0;
    for (int i = 0; i < 1000; ++i) {
      REQUIRE(link.round_trip(sync, 1e6 + i * 20000.0 + (i % 7) * 131.0));
      worst = std::max(worst, std::fabs(cents_of_ppm(sync.ppm() - ppm)));
      CHECK(sync.rate_sigma_ppm() <= 10);
    }
    CHECK(sync.has_prior());
    CHECK(worst < 0.1);  // 58 ppm: from the first sample on
  }
  SECTION("a wrong prior is dropped once the samples disagree, and the fit's own rate takes over") {
    ClockSync sync(16e6);
    sync.set_prior(16e6 * (1 - 2000 / 1e6), 10);  // another board's crystal
    BridgeModel link{ppm};
    for (int i = 0; i < 1000; ++i) REQUIRE(link.round_trip(sync, 1e6 + i * 20000.0 + (i % 7) * 131.0));
    CHECK_FALSE(sync.has_prior());
    CHECK(std::fabs(cents_of_ppm(sync.ppm() - ppm)) < 0.1);
  }
  SECTION("a reset (the board restarted) keeps the prior; without one the rate is nominal until fitted") {
    ClockSync sync(16e6);
    BridgeModel link{ppm};
    for (int i = 0; i < 300; ++i) REQUIRE(link.round_trip(sync, 1e6 + i * 20000.0));
    REQUIRE(sync.has_rate());
    sync.set_prior(sync.ticks_per_s(), sync.rate_sigma_ppm());
    sync.reset();
    CHECK(sync.samples() == 0);
    CHECK(sync.has_rate());
    CHECK(std::fabs(sync.ppm() - ppm) < 200);
    sync.clear_prior();
    sync.reset();
    CHECK_FALSE(sync.has_rate());
    CHECK(sync.ppm() == 0);
  }
}

// test_timeline.cpp: the song player's timeline (player/timeline.h): a refined rate taken about
// the last entry sent, only once the fit's rate is within 30 ppm, and a song played through a
// 16U2 bridge model on a crystal 0.5 % off that stays in order, steps nowhere and comes in tune.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "bridge_model.h"
#include "player/clock_sync.h"
#include "player/timeline.h"

using namespace stepchoir;

TEST_CASE("timeline: a refined rate turns the line about the last entry sent, and later song times take it",
          "[player]") {
  Timeline line;
  line.start(1.0, 5e6, 16e6);
  CHECK(line.ticks(3.0) == 5e6 + 32e6);
  line.follow(3.0, 16.08e6);            // 5,000 ppm fast, from song second 3 on
  CHECK(line.ticks(3.0) == 5e6 + 32e6);  // the pivot keeps its board time
  CHECK(line.ticks(4.5) == Approx(5e6 + 32e6 + 1.5 * 16.08e6).epsilon(1e-15));
  CHECK(line.score(line.ticks(7.25)) == Approx(7.25).epsilon(1e-15));
  CHECK(line.rate == 16.08e6);
}

TEST_CASE("timeline: a fit without a rate, or with one wider than 30 ppm, is not followed", "[player]") {
  ClockSync sync(16e6);
  Timeline line;
  line.start(0, 0, 16e6);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> late(0, 20000);  // up to 20 ms
  auto feed = [&](double from_us, int n) {
    for (int i = 0; i < n; ++i) {
      const double send = from_us + i * 10000.0, stamp = send + 100 + late(rng);  // requests held up
      REQUIRE(sync.add(static_cast<uint64_t>(send), static_cast<uint64_t>(stamp + 100),
                       static_cast<uint32_t>(std::llround(stamp * 16.0 * 1.001))));
    }
  };
  feed(0, 50);  // half a second: no rate yet
  REQUIRE_FALSE(sync.has_rate());
  CHECK_FALSE(line.follow(0.5, sync));
  feed(0.5e6, 70);  // 1.2 s through a link this noisy: a rate, but a wide one
  REQUIRE(sync.has_rate());
  INFO("the fit's rate " << sync.ppm() << " ppm, its standard error " << sync.rate_sigma_ppm() << " ppm");
  REQUIRE(sync.rate_sigma_ppm() > Timeline::kRateSigmaPpm);
  CHECK_FALSE(line.follow(1.2, sync));
  CHECK(line.rate == 16e6);
  CHECK(line.ticks(1.2) == 1.2 * 16e6);
}

// The player's loop on a model link: a clock round trip every 10 ms (golden-ratio steps through
// the USB frame), a second of sync and then until the rate is within 30 ppm, the line started
// one lead (0.3 s) ahead, and an eighth note every 0.125 s for 12 s, each sent a lead before its
// time, the line following the fit after every sample.
TEST_CASE("timeline: a song through a 16U2 bridge on a crystal 0.5 % off follows the refined rate - in order, "
          "no step, in tune from 2 s and within 0.1 cent after 10 s",
          "[player]") {
  for (double ppm : {-5000.0, 5000.0}) {
    BridgeModel link{ppm};
    ClockSync sync(16e6);
    Timeline line;
    const double lead_s = 0.3, note_s = 0.125;
    const int notes = 96;
    struct Sent {
      double score_s, ticks, rate;
    };
    std::vector<Sent> sent;
    double dither = 0, t_us = 0, pivot_s = 0;
    int follows = 0;
    bool playing = false;
    for (int i = 0; sent.size() < size_t(notes) && i < 3000; ++i) {
      dither = std::fmod(dither + 0.6180339887, 1.0);
      t_us = i * 10000.0 + dither * 1000;
      REQUIRE(link.round_trip(sync, t_us));
      if (!playing) {
        if (t_us < 1e6 || !sync.has_rate() || sync.rate_sigma_ppm() > Timeline::kRateSigmaPpm) continue;
        line.start(0, sync.ticks_at(t_us) + lead_s * sync.ticks_per_s(), sync.ticks_per_s());
        playing = true;
      }
      follows += line.follow(pivot_s, sync);
      const double now_ticks = sync.ticks_at(t_us);
      while (sent.size() < size_t(notes)) {
        const double score = static_cast<double>(sent.size()) * note_s;
        if (line.ticks(score) - now_ticks > lead_s * line.rate) break;
        sent.push_back({score, line.ticks(score), line.rate});
        pivot_s = score;
      }
    }
    REQUIRE(sent.size() == size_t(notes));
    CHECK(follows > 100);  // the line took the fit's rate again and again
    // Real time (the board's true clock) of each note; the tempo of each step between notes
    // and each note's pitch (its period at the rate it was sent with) against the song's.
    double worst_step_2s = 0, worst_step_10s = 0, worst_cents_2s = 0, worst_cents_10s = 0;
    const double true_rate = 16e6 * (1 + ppm / 1e6);
    for (size_t k = 0; k < sent.size(); ++k) {
      const double pitch_cents = std::fabs(cents_of_ppm((true_rate / sent[k].rate - 1) * 1e6));
      if (k > 0) {
        REQUIRE(sent[k].ticks > sent[k - 1].ticks);  // in order: song time never steps back
        const double real_s = (link.host_us(sent[k].ticks) - link.host_us(sent[k - 1].ticks)) / 1e6;
        const double step_ppm = std::fabs(real_s / note_s - 1) * 1e6;
        if (sent[k].score_s >= 2) worst_step_2s = std::max(worst_step_2s, step_ppm);
        if (sent[k].score_s >= 10) worst_step_10s = std::max(worst_step_10s, step_ppm);
      }
      if (sent[k].score_s >= 2) worst_cents_2s = std::max(worst_cents_2s, pitch_cents);
      if (sent[k].score_s >= 10) worst_cents_10s = std::max(worst_cents_10s, pitch_cents);
    }
    std::printf("timeline, 16U2 link, crystal %+.0f ppm, %d follows: from 2 s, note steps within %.1f ppm, pitch "
                "%.4f cent; from 10 s, %.1f ppm, %.4f cent\n",
                ppm, follows, worst_step_2s, worst_cents_2s, worst_step_10s, worst_cents_10s);
    // A step in the timeline (the line turned about another point than the last entry sent)
    // shows as one interval off by the step: 10 s into the song, 10 ppm of rate is 100 us, 800
    // ppm of an eighth. Issue 23's targets: 0.5 cent from 2 s, 0.1 cent after 10 s.
    CHECK(worst_step_2s < 289);   // 0.5 cent of tempo
    CHECK(worst_step_10s < 58);   // 0.1 cent
    CHECK(worst_cents_2s < 0.5);
    CHECK(worst_cents_10s < 0.1);
  }
}

// test_drums.cpp: the drum voice as a listener hears it. A kit of eight General MIDI kinds
// (tests/data/songs/drum-kit.mid) plays on one motor through `stepchoir render --drums 0` and
// the real firmware on the virtual board; the hits are measured in the WAV the command writes.
// Every kind must sound different from every other: 3 semitones apart in pitch or 1.5 times
// in length, and the registers in a kit's order.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "e2e_util.h"
#include "hit_sound.h"
#include "play_checks.h"
#include "player/drum_voice.h"
#include "render.h"
#include "trace.h"

using namespace stepchoir;
using namespace play_checks;
using e2e::scratch;

namespace {

struct Kind {
  const char *name;
  uint8_t gm_key;
};
// The kit's order in drum-kit.mid: four hits of each.
const Kind kKit[] = {{"kick", 36}, {"low tom", 45}, {"high tom", 50}, {"snare", 38},
                     {"ride", 51}, {"crash", 49},   {"open hat", 46}, {"closed hat", 42}};
constexpr size_t kHitsPerKind = 4;
constexpr double kDistinctSemitones = 3;
constexpr double kDistinctLengthRatio = 1.5;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST_CASE("render: each drum kind sounds distinct in the WAV, in a kit's registers", "[play]") {
  const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/drum-kit.mid";
  const std::string wav = scratch("drum-kit.wav"), trace_path = scratch("drum-kit.csv");
  int status = -1;
  const std::string out = run_stepchoir({"render", song, "--drums", "0", "-o", wav, "--trace", trace_path}, &status);
  INFO(out);
  REQUIRE(status == 0);
  const auto t = sc::trace::read_trace(trace_path);
  int rate = 0;
  const std::vector<int16_t> samples = sc::trace::read_wav(wav, &rate);
  const std::vector<sc::trace::HitSound> hits = sc::trace::measure_hits(t, 0, samples, rate);
  REQUIRE(hits.size() == std::size(kKit) * kHitsPerKind);
  struct Heard {
    double note, length_s, level_db;
  };
  std::vector<Heard> heard;
  for (size_t k = 0; k < std::size(kKit); ++k) {
    std::vector<double> notes, lengths, levels;
    for (size_t i = 0; i < kHitsPerKind; ++i) {
      const sc::trace::HitSound &h = hits[k * kHitsPerKind + i];
      notes.push_back(h.midi_note);
      lengths.push_back(h.heard_s);
      levels.push_back(h.peak_dbfs);
    }
    heard.push_back({median(notes), median(lengths), median(levels)});
    INFO(kKit[k].name << ": note " << heard.back().note << ", heard " << heard.back().length_s * 1000 << " ms, "
                      << heard.back().level_db << " dBFS");
    // the motor plays the burst as designed (no fold: the default range takes every burst)
    CHECK(heard.back().note == Approx(drum_burst(kKit[k].gm_key).note).margin(0.1));
    CHECK(heard.back().length_s > 0.01);
  }
  for (size_t a = 0; a < heard.size(); ++a)
    for (size_t b = a + 1; b < heard.size(); ++b) {
      INFO(kKit[a].name << " (note " << heard[a].note << ", " << heard[a].length_s * 1000 << " ms) vs " << kKit[b].name
                        << " (note " << heard[b].note << ", " << heard[b].length_s * 1000 << " ms)");
      const double semitones = std::fabs(heard[a].note - heard[b].note);
      const double ratio = std::max(heard[a].length_s, heard[b].length_s) / std::min(heard[a].length_s, heard[b].length_s);
      CHECK((semitones >= kDistinctSemitones || ratio >= kDistinctLengthRatio));
    }
  // Registers: kick under the toms under the snare, the metal far above.
  CHECK(heard[0].note < heard[1].note);
  CHECK(heard[1].note < heard[2].note);
  CHECK(heard[2].note < heard[3].note);
  for (size_t k = 4; k < heard.size(); ++k) CHECK(heard[k].note > heard[3].note + 24);
  // The closed hat is the shortest sound; the crash rings longest.
  for (size_t k = 0; k < heard.size(); ++k) {
    if (k != 7) CHECK(heard[7].length_s < heard[k].length_s);
    if (k != 5) CHECK(heard[5].length_s > heard[k].length_s);
  }
}

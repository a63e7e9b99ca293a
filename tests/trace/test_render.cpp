// test_render.cpp: WAV length, header, level and pitch; PNG validity and what the roll shows.
#include <catch2/catch.hpp>

#include <png.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include "render.h"
#include "synth_trace.h"

using namespace sc::trace;

namespace {

// Reads a whole file as bytes.
std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Little-endian 16-bit value at an offset.
uint32_t le16(const std::string& b, size_t at) { return uint8_t(b[at]) | uint32_t(uint8_t(b[at + 1])) << 8; }

// Little-endian 32-bit value at an offset.
uint32_t le32(const std::string& b, size_t at) { return le16(b, at) | le16(b, at + 2) << 16; }

// Big-endian 32-bit value at an offset (PNG).
uint32_t be32(const std::string& b, size_t at) {
  return uint32_t(uint8_t(b[at])) << 24 | uint32_t(uint8_t(b[at + 1])) << 16 | uint32_t(uint8_t(b[at + 2])) << 8 |
         uint8_t(b[at + 3]);
}

// Normalised autocorrelation of samples [begin, end) at a lag.
double autocorrelation(const std::vector<int16_t>& s, size_t begin, size_t end, size_t lag) {
  double num = 0, den = 0;
  for (size_t i = begin; i + lag < end; ++i) {
    num += double(s[i]) * s[i + lag];
    den += double(s[i]) * s[i];
  }
  return den > 0 ? num / den : 0;
}

// Whether a pixel of the image has exactly this colour.
bool is_colour(const Image& img, int x, int y, Rgb c) {
  const uint8_t* p = &img.rgb[(size_t(y) * size_t(img.width_px) + size_t(x)) * 3];
  return p[0] == c.r && p[1] == c.g && p[2] == c.b;
}

}  // namespace

TEST_CASE("WAV: length follows real time - header is canonical 16-bit mono", "[render]") {
  const double kEndS = 1.2, kPpm = 100;
  Trace t = parse_trace(synth::make_trace_text({{{69, 0.1, 1.0}}}, kEndS, kPpm));
  const int rate = kDefaultSampleRateHz;
  const size_t expected = size_t(std::ceil(kEndS / (1 + kPpm / kPpmPerUnit) * rate));
  CHECK(audio_length_samples(t, rate) == expected);
  CHECK(expected == 52915);  // 1.2 s less 100 ppm at 44.1 kHz, by hand
  std::vector<int16_t> samples = render_audio(t);
  REQUIRE(samples.size() == expected);
  std::string path = (synth::scratch_dir() / "a4.wav").string();
  write_wav(path, samples, kDefaultSampleRateHz);
  std::string b = slurp(path);
  REQUIRE(b.size() == kWavHeaderBytes + 2 * expected);
  CHECK(b.substr(0, 4) == "RIFF");
  CHECK(le32(b, 4) == b.size() - 8);
  CHECK(b.substr(8, 4) == "WAVE");
  CHECK(b.substr(12, 4) == "fmt ");
  CHECK(le32(b, 16) == 16u);
  CHECK(le16(b, 20) == 1u);      // PCM
  CHECK(le16(b, 22) == 1u);      // mono
  CHECK(le32(b, 24) == uint32_t(rate));      // sample rate
  CHECK(le32(b, 28) == uint32_t(2 * rate));  // byte rate: 2 bytes a sample
  CHECK(le16(b, 32) == 2u);      // block align
  CHECK(le16(b, 34) == 16u);     // bits
  CHECK(b.substr(36, 4) == "data");
  CHECK(le32(b, 40) == 2 * expected);
  CHECK(int16_t(le16(b, 44 + 2 * 5000)) == samples[5000]);
  int read_rate = 0;
  CHECK(read_wav(path, &read_rate) == samples);  // read back as written
  CHECK(read_rate == rate);
  { std::ofstream(path, std::ios::binary) << b.substr(0, 40); }
  CHECK_THROWS_WITH(read_wav(path, &read_rate), Catch::Contains("not a canonical WAV file"));
  { std::ofstream(path, std::ios::binary) << b.substr(0, 1000); }
  CHECK_THROWS_WITH(read_wav(path, &read_rate), Catch::Contains("data chunk of"));
}

TEST_CASE("WAV: peak at -1 dBFS - silent before the first step - rings at the step rate", "[render]") {
  Trace t = parse_trace(synth::make_trace_text({{{69, 0.1, 0.5}}, {}}, 0.8));
  std::vector<int16_t> s = render_audio(t);
  int peak = 0;
  for (int16_t v : s) peak = std::max(peak, std::abs(int(v)));
  CHECK(peak == Approx(32767 * std::pow(10.0, AudioOptions().peak_dbfs / 20)).margin(1));
  CHECK(peak == 29204);  // -1 dBFS of 32767, by hand
  const size_t first_step = size_t(0.1 * kDefaultSampleRateHz);
  for (size_t i = 0; i < first_step; ++i) REQUIRE(s[i] == 0);
  // the strongest repetition between 2 ms and 9 ms is one step period: 44100 / 440 = 100.2 samples
  size_t best_lag = 0;
  double best = -1;
  for (size_t lag = 88; lag < 400; ++lag) {
    double r = autocorrelation(s, first_step, first_step + 20000, lag);
    if (r > best) best = r, best_lag = lag;
  }
  CHECK((best_lag == 100 || best_lag == 101));
  CHECK(best > 0.8);
  // and the tail after the last step has died away
  CHECK(std::abs(int(s.back())) < 10);
}

TEST_CASE("WAV: refuses absurdly long traces instead of allocating gigabytes", "[render]") {
  Trace t = parse_trace(synth::make_trace_text({{}}, 0.1));
  t.end_cycle = uint64_t(1e15);  // two years
  CHECK_THROWS_WITH(render_audio(t), Catch::Contains("audio is limited"));
}

TEST_CASE("WAV: the sample rate scales the length - a trace without steps is silence", "[render]") {
  Trace t = parse_trace(synth::make_trace_text({{{60, 0, 0.5}}}, 1.0));
  AudioOptions low;
  low.sample_rate_hz = kDefaultSampleRateHz / 2;
  CHECK(render_audio(t, low).size() == size_t(kDefaultSampleRateHz / 2));  // 1 s
  Trace quiet = parse_trace(synth::make_trace_text({{}, {}}, 0.25));
  std::vector<int16_t> s = render_audio(quiet);
  CHECK(s.size() == size_t(kDefaultSampleRateHz / 4));  // 0.25 s
  for (int16_t v : s) REQUIRE(v == 0);
  // each motor rings at its own frequency, below Nyquist
  AudioOptions def;
  CHECK(resonator_hz(def, 1) > resonator_hz(def, 0));
  CHECK(resonator_hz(def, 40) < def.sample_rate_hz / 2.0);
}

TEST_CASE("PNG: valid file with the right IHDR - libpng reads it back", "[render]") {
  Trace t = parse_trace(synth::make_trace_text(synth::three_motor_scale(), 5.5));
  std::string path = (synth::scratch_dir() / "scale.png").string();
  write_png(path, render_piano_roll(t));
  std::string b = slurp(path);
  REQUIRE(b.size() > 33);
  CHECK(b.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
  CHECK(be32(b, 8) == 13u);
  CHECK(b.substr(12, 4) == "IHDR");
  CHECK(be32(b, 16) == uint32_t(kDefaultRollWidthPx));
  CHECK(be32(b, 20) == uint32_t(kDefaultRollHeightPx));
  CHECK(uint8_t(b[24]) == 8);  // bit depth
  CHECK(uint8_t(b[25]) == 2);  // RGB
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  REQUIRE(png_image_begin_read_from_file(&image, path.c_str()) != 0);
  image.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(image));
  REQUIRE(png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr) != 0);
  CHECK(image.width == uint32_t(kDefaultRollWidthPx));
}

TEST_CASE("piano roll: each motor's notes appear - higher notes higher - in time order", "[render]") {
  // motor 0 plays C5 then later G5; motor 1 plays C3 throughout
  Trace t = parse_trace(synth::make_trace_text({{{72, 0, 1}, {79, 2, 1}}, {{48, 0, 3}}}, 3.0));
  Image img = render_piano_roll(t);
  REQUIRE(img.width_px == kDefaultRollWidthPx);
  REQUIRE(img.height_px == kDefaultRollHeightPx);
  REQUIRE(img.rgb.size() == size_t(img.width_px * img.height_px * 3));
  const int kBelowLegendPx = 24;  // the legend swatches sit above this row
  // for each motor colour: the rows it occupies in the first and the last third of the time axis
  auto rows_of = [&](int motor, int x_from, int x_to) {  // mean y of the motor's pixels in a column band
    double sum = 0;
    int count = 0;
    for (int y = kBelowLegendPx; y < img.height_px; ++y)
      for (int x = x_from; x < x_to; ++x)
        if (is_colour(img, x, y, motor_rgb(motor))) sum += y, ++count;
    return count ? sum / count : -1.0;
  };
  const int third = img.width_px / 3;
  double m0_early = rows_of(0, 60, third - 20), m0_late = rows_of(0, 2 * third + 20, img.width_px - 30);
  double m1_early = rows_of(1, 60, third - 20), m1_late = rows_of(1, 2 * third + 20, img.width_px - 30);
  REQUIRE(m0_early > 0);
  REQUIRE(m0_late > 0);
  REQUIRE(m1_early > 0);
  CHECK(m0_late < m0_early);   // G5 above C5
  CHECK(m1_early > m0_early);  // C3 below C5
  CHECK(m1_late == Approx(m1_early).margin(1));
  // the middle third has no note of motor 0 (silence from 1 s to 2 s)
  CHECK(rows_of(0, third + 60, 2 * third - 20) < 0);
  // a C5 - G5 - C3 roll spans C3..G5: rows per semitone = plot height / span, so bars are 7 semitones apart
  CHECK((m0_early - m0_late) / (m1_early - m0_early) == Approx(7.0 / 24).epsilon(0.05));
}

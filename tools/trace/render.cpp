// render.cpp: WAV synthesis (damped resonator per motor) and the PNG piano roll (see render.h).
#include "render.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <utility>

namespace sc {
namespace trace {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInt16FullScale = 32767.0;
constexpr double kDbPerAmplitudeDecade = 20.0;
constexpr double kResonatorSpread = 1.25;      // each motor rings this much higher than the last
constexpr double kMaxResonatorFraction = 0.4;  // of the sample rate: stay well below Nyquist
constexpr double kMaxAudioSeconds = 3600;     // longer traces would need gigabytes of samples
constexpr uint16_t kWavFormatPcm = 1;
constexpr uint16_t kWavChannels = 1;
constexpr uint16_t kWavBitsPerSample = 16;
constexpr uint32_t kWavBytesPerSample = kWavBitsPerSample / 8;
constexpr uint32_t kWavFmtChunkBytes = 16;

}  // namespace

// ---------------------------------------------------------------------------------------------
// Audio
// ---------------------------------------------------------------------------------------------

size_t audio_length_samples(const Trace& trace, int sample_rate_hz) {
  if (sample_rate_hz <= 0 || !(trace.f_cpu_hz > 0)) return 0;
  return size_t(std::ceil(trace.real_seconds(trace.end_cycle) * double(sample_rate_hz)));
}

double resonator_hz(const AudioOptions& options, int motor) {
  double hz = options.resonator_base_hz * std::pow(kResonatorSpread, double(motor));
  return std::min(hz, kMaxResonatorFraction * double(options.sample_rate_hz));
}

std::vector<int16_t> render_audio(const Trace& trace, const AudioOptions& options) {
  if (options.sample_rate_hz <= 0) throw std::invalid_argument("render_audio: sample rate must be > 0");
  if (!(options.resonator_decay_s > 0)) throw std::invalid_argument("render_audio: decay must be > 0");
  const size_t n = audio_length_samples(trace, options.sample_rate_hz);
  const double rate_hz = double(options.sample_rate_hz);
  if (double(n) > kMaxAudioSeconds * rate_hz)
    throw std::runtime_error("trace lasts " + std::to_string(trace.real_seconds(trace.end_cycle)) +
                             " s; audio is limited to " + std::to_string(int(kMaxAudioSeconds)) + " s");
  std::vector<float> mix(n, 0.0f);
  for (int m = 0; m < int(trace.motor.size()); ++m) {
    const std::vector<Step>& steps = trace.motor[size_t(m)].steps;
    if (steps.empty()) continue;
    // two-pole resonator: impulse response r^k sin((k+1) w) / sin w, scaled to peak ~1
    const double w = 2.0 * kPi * resonator_hz(options, m) / rate_hz;
    const double r = std::exp(-1.0 / (options.resonator_decay_s * rate_hz));
    const double a1 = 2.0 * r * std::cos(w), a2 = -r * r, gain = std::sin(w);
    double y1 = 0, y2 = 0;
    double carry = 0;  // the part of the last impulse that falls on the next sample
    size_t next_step = 0;
    for (size_t k = 0; k < n; ++k) {
      double x = carry;
      carry = 0;
      // split each impulse over two samples: sub-sample timing keeps the pitch clean
      for (; next_step < steps.size(); ++next_step) {
        double at_samples = trace.real_seconds(steps[next_step].rise_cycle) * rate_hz;
        if (at_samples >= double(k + 1)) break;
        double frac = std::max(0.0, at_samples - double(k));
        x += 1.0 - frac;
        carry += frac;
      }
      double y = gain * x + a1 * y1 + a2 * y2;
      y2 = y1;
      y1 = y;
      mix[k] += float(y);
    }
  }
  double peak = 0;
  for (float v : mix) peak = std::max(peak, double(std::fabs(v)));
  std::vector<int16_t> out(n, 0);
  if (peak <= 0) return out;
  const double scale = kInt16FullScale * std::pow(10.0, options.peak_dbfs / kDbPerAmplitudeDecade) / peak;
  for (size_t k = 0; k < n; ++k) {
    double v = std::round(double(mix[k]) * scale);
    out[k] = int16_t(std::max(-kInt16FullScale, std::min(kInt16FullScale, v)));
  }
  return out;
}

namespace {

// Appends a little-endian 16-bit value.
void put_u16(std::string& out, uint16_t v) {
  out += char(v & 0xff);
  out += char(v >> 8);
}

// Appends a little-endian 32-bit value.
void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out += char((v >> (8 * i)) & 0xff);
}

}  // namespace

void write_wav(const std::string& path, const std::vector<int16_t>& samples, int sample_rate_hz) {
  if (sample_rate_hz <= 0) throw std::invalid_argument("write_wav: sample rate must be > 0");
  const uint64_t data_bytes = uint64_t(samples.size()) * kWavBytesPerSample;
  if (data_bytes + kWavHeaderBytes > 0xffffffffull) throw std::runtime_error(path + ": too long for WAV");
  std::string out;
  out.reserve(kWavHeaderBytes + size_t(data_bytes));
  out += "RIFF";
  put_u32(out, uint32_t(kWavHeaderBytes - 8 + data_bytes));
  out += "WAVE";
  out += "fmt ";
  put_u32(out, kWavFmtChunkBytes);
  put_u16(out, kWavFormatPcm);
  put_u16(out, kWavChannels);
  put_u32(out, uint32_t(sample_rate_hz));
  put_u32(out, uint32_t(sample_rate_hz) * kWavChannels * kWavBytesPerSample);  // byte rate
  put_u16(out, uint16_t(kWavChannels * kWavBytesPerSample));                  // block align
  put_u16(out, kWavBitsPerSample);
  out += "data";
  put_u32(out, uint32_t(data_bytes));
  for (int16_t s : samples) put_u16(out, uint16_t(s));
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
  file.write(out.data(), std::streamsize(out.size()));
  file.close();
  if (!file) throw std::runtime_error(path + ": write failed");
}

// ---------------------------------------------------------------------------------------------
// Piano roll
// ---------------------------------------------------------------------------------------------

namespace {

constexpr int kGlyphWidthPx = 5;
constexpr int kGlyphHeightPx = 7;
constexpr int kGlyphAdvancePx = kGlyphWidthPx + 1;

// A 5x7 bitmap glyph: 7 rows of 5 characters, '#' = ink.
struct Glyph {
  char ch;
  const char* rows;  // 35 characters, row by row
};

// Upper-case font; lower case is drawn as upper case.
const Glyph kFont[] = {
    {' ', "..................................."},
    {'0', ".###.#...##..###.#.###..##...#.###."},
    {'1', "..#...##....#....#....#....#...###."},
    {'2', ".###.#...#....#...#...#...#...#####"},
    {'3', "####.....#....#.###.....#....#####."},
    {'4', "...#...##..#.#.#..#.#####...#....#."},
    {'5', "######....####.....#....##...#.###."},
    {'6', "..##..#...#....####.#...##...#.###."},
    {'7', "#####....#...#...#...#....#....#..."},
    {'8', ".###.#...##...#.###.#...##...#.###."},
    {'9', ".###.#...##...#.####....#...#..##.."},
    {'A', ".###.#...##...#######...##...##...#"},
    {'B', "####.#...##...#####.#...##...#####."},
    {'C', ".###.#...##....#....#....#...#.###."},
    {'D', "###..#..#.#...##...##...##..#.###.."},
    {'E', "######....#....####.#....#....#####"},
    {'F', "######....#....####.#....#....#...."},
    {'G', ".###.#...##....#.####...##...#.####"},
    {'H', "#...##...##...#######...##...##...#"},
    {'I', ".###...#....#....#....#....#...###."},
    {'J', "..###...#....#....#....#.#..#..##.."},
    {'K', "#...##..#.#.#..##...#.#..#..#.#...#"},
    {'L', "#....#....#....#....#....#....#####"},
    {'M', "#...###.###.#.##.#.##...##...##...#"},
    {'N', "#...##...###..##.#.##..###...##...#"},
    {'O', ".###.#...##...##...##...##...#.###."},
    {'P', "####.#...##...#####.#....#....#...."},
    {'Q', ".###.#...##...##...##.#.##..#..##.#"},
    {'R', "####.#...##...#####.#.#..#..#.#...#"},
    {'S', ".#####....#.....###.....#....#####."},
    {'T', "#####..#....#....#....#....#....#.."},
    {'U', "#...##...##...##...##...##...#.###."},
    {'V', "#...##...##...##...##...#.#.#...#.."},
    {'W', "#...##...##...##.#.##.#.##.#.#.#.#."},
    {'X', "#...##...#.#.#...#...#.#.#...##...#"},
    {'Y', "#...##...#.#.#...#....#....#....#.."},
    {'Z', "#####....#...#...#...#...#....#####"},
    {'.', "..........................##...##.."},
    {',', ".....................##....#...#..."},
    {':', "......##...##........##...##......."},
    {'-', "................###................"},
    {'+', ".......#....#..#####..#....#......."},
    {'=', "..........#####.....#####.........."},
    {'#', ".#.#..#.#.#####.#.#.#####.#.#..#.#."},
    {'/', ".........#...#...#...#...#........."},
    {'(', "...#...#...#....#....#.....#.....#."},
    {')', ".#.....#.....#....#....#...#...#..."},
    {'%', "##...##..#...#...#...#...#..##...##"},
    {'_', "..............................#####"},
    {'?', ".###.#...#....#...#...#.........#.."},
};

// The glyph for a character ('?' for ones the font lacks).
const char* glyph_rows(char c) {
  c = char(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kFont)
    if (g.ch == c) return g.rows;
  return glyph_rows('?');
}

constexpr Rgb kPageRgb{255, 255, 255};
constexpr Rgb kBlackKeyRowRgb{241, 242, 246};
constexpr Rgb kOctaveLineRgb{150, 152, 165};
constexpr Rgb kSecondLineRgb{226, 228, 234};
constexpr Rgb kLabelLineRgb{200, 202, 212};
constexpr Rgb kFrameRgb{120, 122, 135};
constexpr Rgb kTextRgb{40, 42, 54};
constexpr Rgb kFaintTextRgb{150, 152, 165};
constexpr Rgb kReversalRgb{20, 20, 20};
// One colour per motor (Tableau 10), repeated past ten motors.
constexpr std::array<Rgb, 10> kMotorRgb{{{31, 119, 180},
                                          {255, 127, 14},
                                          {44, 160, 44},
                                          {214, 39, 40},
                                          {148, 103, 189},
                                          {140, 86, 75},
                                          {227, 119, 194},
                                          {127, 127, 127},
                                          {188, 189, 34},
                                          {23, 190, 207}}};

constexpr int kMarginLeftPx = 44;
constexpr int kMarginRightPx = 16;
constexpr int kMarginTopPx = 30;
constexpr int kMarginBottomPx = 24;
constexpr int kTitleTopPx = 10;
constexpr int kPitchPadSemitones = 2;    // empty rows above and below the notes
constexpr int kMinSpanSemitones = 13;    // show at least an octave (C to C)
constexpr int kDefaultLowMidi = 48;      // range shown when no note was played (C3..C5)
constexpr int kDefaultHighMidi = 72;
constexpr int kSemitonesPerOctaveInt = int(kSemitonesPerOctave);
constexpr int kMidiOctaveOffset = 1;     // MIDI 60 is C4: octave = midi / 12 - 1
constexpr double kMinGridSpacingPx = 6;  // draw a line every second only if they are this far apart
constexpr double kMinLabelSpacingPx = 44;
constexpr double kBarFillOfRow = 0.7;    // note bar height as a fraction of a semitone row
constexpr int kMinBarHeightPx = 3;
constexpr int kTickOverhangPx = 3;       // reversal tick sticks out this far above/below the bar
constexpr int kMinOutlinedBarPx = 5;    // thinner bars get no outline
constexpr double kInsetOfBar = 0.3;      // a unison bar is this much (of the bar) smaller each side
constexpr int kMinInsetPx = 1;
constexpr double kMinRowForAllLabelsPx = 9;  // label D, E, F, ... too when rows are this tall
constexpr int kLegendSwatchPx = 9;
constexpr int kLegendSwatchGapPx = 4;   // between a swatch and its label
constexpr int kLabelGapPx = 6;          // between the plot frame and axis labels
constexpr int kMinOutlinedBarWidthPx = 3;
constexpr int kLegendGapPx = 14;
constexpr double kOutlineShade = 0.6;    // bar outline = motor colour times this
// Time grid steps to choose from, in seconds.
constexpr std::array<double, 12> kTimeStepsS{{1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 1200, 3600}};

// A drawing surface over an Image, clipping everything to the picture.
class Canvas {
 public:
  // Makes a canvas of the given size filled with a colour.
  Canvas(int width_px, int height_px, Rgb fill) {
    image_.width_px = width_px;
    image_.height_px = height_px;
    image_.rgb.resize(size_t(width_px) * size_t(height_px) * 3);
    for (size_t i = 0; i < image_.rgb.size(); i += 3) {
      image_.rgb[i] = fill.r;
      image_.rgb[i + 1] = fill.g;
      image_.rgb[i + 2] = fill.b;
    }
  }
  // Sets one pixel (ignored outside the picture).
  void pixel(int x, int y, Rgb c) {
    if (x < 0 || y < 0 || x >= image_.width_px || y >= image_.height_px) return;
    uint8_t* p = &image_.rgb[(size_t(y) * size_t(image_.width_px) + size_t(x)) * 3];
    p[0] = c.r;
    p[1] = c.g;
    p[2] = c.b;
  }
  // Fills the rectangle [x0, x1) x [y0, y1).
  void fill(int x0, int y0, int x1, int y1, Rgb c) {
    x0 = std::max(x0, 0);
    y0 = std::max(y0, 0);
    x1 = std::min(x1, image_.width_px);
    y1 = std::min(y1, image_.height_px);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) pixel(x, y, c);
  }
  // Draws a horizontal line from x0 to x1 (exclusive) at row y.
  void hline(int x0, int x1, int y, Rgb c) { fill(x0, y, x1, y + 1, c); }
  // Draws a vertical line from y0 to y1 (exclusive) at column x.
  void vline(int x, int y0, int y1, Rgb c) { fill(x, y0, x + 1, y1, c); }
  // Draws the outline of the rectangle [x0, x1) x [y0, y1).
  void frame(int x0, int y0, int x1, int y1, Rgb c) {
    hline(x0, x1, y0, c);
    hline(x0, x1, y1 - 1, c);
    vline(x0, y0, y1, c);
    vline(x1 - 1, y0, y1, c);
  }
  // Draws text with its top-left corner at (x, y).
  void text(int x, int y, const std::string& s, Rgb c) {
    for (char ch : s) {
      const char* rows = glyph_rows(ch);
      for (int gy = 0; gy < kGlyphHeightPx; ++gy)
        for (int gx = 0; gx < kGlyphWidthPx; ++gx)
          if (rows[gy * kGlyphWidthPx + gx] == '#') pixel(x + gx, y + gy, c);
      x += kGlyphAdvancePx;
    }
  }
  // Width of a text in pixels.
  static int text_width_px(const std::string& s) {
    return s.empty() ? 0 : int(s.size()) * kGlyphAdvancePx - 1;
  }
  // Hands over the finished picture.
  Image take() { return std::move(image_); }

 private:
  Image image_;
};

// Scales a colour towards black.
Rgb shade(Rgb c, double factor) {
  return Rgb{uint8_t(c.r * factor), uint8_t(c.g * factor), uint8_t(c.b * factor)};
}

// Floor division for note names of negative MIDI numbers.
int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// Whether a MIDI note is a black key.
bool is_black_key(int midi) {
  int pitch_class = midi - floor_div(midi, kSemitonesPerOctaveInt) * kSemitonesPerOctaveInt;
  return pitch_class == 1 || pitch_class == 3 || pitch_class == 6 || pitch_class == 8 || pitch_class == 10;
}

// Note letter of each pitch class ('#' rows are never labelled).
constexpr char kPitchClassLetters[] = "C#D#EF#G#A#B";

// Appends the time spans (cycles) in which a note of another motor sounds the same semitone as n.
void append_unison_spans(const std::vector<NoteSegment>& others, const NoteSegment& n,
                         std::vector<std::pair<uint64_t, uint64_t>>& spans) {
  // notes of one motor are in time order and do not overlap, so look back from the last one
  // starting before n ends
  auto it = std::lower_bound(others.begin(), others.end(), n.end_cycle,
                             [](const NoteSegment& o, uint64_t cycle) { return o.start_cycle < cycle; });
  while (it != others.begin()) {
    --it;
    if (it->end_cycle <= n.start_cycle) break;
    if (std::lround(it->midi_note) == std::lround(n.midi_note))
      spans.emplace_back(std::max(it->start_cycle, n.start_cycle), std::min(it->end_cycle, n.end_cycle));
  }
}

// Formats a number with a fixed count of decimals.
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

// Colour of a motor: the palette, repeated past its end.
Rgb motor_rgb(int motor) { return kMotorRgb[size_t(motor) % kMotorRgb.size()]; }

Image render_piano_roll(const Trace& trace, const RollOptions& options) {
  const int width_px = std::max(options.width_px, kMarginLeftPx + kMarginRightPx + 1);
  const int height_px = std::max(options.height_px, kMarginTopPx + kMarginBottomPx + 1);
  Canvas canvas(width_px, height_px, kPageRgb);
  const int plot_x0 = kMarginLeftPx, plot_x1 = width_px - kMarginRightPx;
  const int plot_y0 = kMarginTopPx, plot_y1 = height_px - kMarginBottomPx;
  const double plot_w_px = plot_x1 - plot_x0, plot_h_px = plot_y1 - plot_y0;

  // notes of every motor, and the ranges they span
  std::vector<std::vector<NoteSegment>> notes(trace.motor.size());
  double low_midi = 0, high_midi = 0, end_s = trace.real_seconds(trace.end_cycle);
  bool any_note = false;
  for (size_t m = 0; m < trace.motor.size(); ++m) {
    notes[m] = segment_notes(trace.motor[m].steps, trace.f_cpu_hz, options.segments);
    for (const NoteSegment& n : notes[m]) {
      low_midi = any_note ? std::min(low_midi, n.midi_note) : n.midi_note;
      high_midi = any_note ? std::max(high_midi, n.midi_note) : n.midi_note;
      any_note = true;
      end_s = std::max(end_s, trace.real_seconds(n.end_cycle));
    }
  }
  int lo = kDefaultLowMidi, hi = kDefaultHighMidi;
  if (any_note) {
    lo = int(std::floor(low_midi + 0.5)) - kPitchPadSemitones;
    hi = int(std::floor(high_midi + 0.5)) + kPitchPadSemitones;
    while (hi - lo + 1 < kMinSpanSemitones) {  // widen symmetrically to at least an octave
      if ((hi - lo) % 2 == 0) ++hi; else --lo;
    }
  }
  const int rows = hi - lo + 1;
  const double row_h_px = plot_h_px / rows;
  if (!(end_s > 0)) end_s = 1;
  const double px_per_s = plot_w_px / end_s;
  // y of the centre of a (fractional) MIDI pitch.
  auto y_of = [&](double midi) { return plot_y1 - (midi - lo + 0.5) * row_h_px; };
  // x of a real time in seconds.
  auto x_of = [&](double s) { return plot_x0 + s * px_per_s; };

  // semitone rows: black keys shaded, a line under every C, labelled
  for (int midi = lo; midi <= hi; ++midi) {
    int top = int(std::lround(y_of(midi + 0.5))), bottom = int(std::lround(y_of(midi - 0.5)));
    if (is_black_key(midi)) canvas.fill(plot_x0, top, plot_x1, bottom, kBlackKeyRowRgb);
  }
  // time grid: a line each second when they fit, labels where they do not crowd
  double label_step_s = kTimeStepsS.back();
  for (double step : kTimeStepsS)
    if (step * px_per_s >= kMinLabelSpacingPx) {
      label_step_s = step;
      break;
    }
  const double grid_step_s = px_per_s >= kMinGridSpacingPx ? 1.0 : label_step_s;
  const long label_every = std::max(1L, std::lround(label_step_s / grid_step_s));
  for (long k = 0; k * grid_step_s <= end_s; ++k) {
    double t = k * grid_step_s;
    int x = int(std::lround(x_of(t)));
    bool labelled = k % label_every == 0;
    canvas.vline(x, plot_y0, plot_y1, labelled ? kLabelLineRgb : kSecondLineRgb);
    if (labelled) {
      std::string label = fixed(t, 0);
      canvas.text(x - Canvas::text_width_px(label) / 2, plot_y1 + kLabelGapPx, label, kTextRgb);
    }
  }
  canvas.text(2, plot_y1 + kLabelGapPx, "SEC", kTextRgb);
  // a line under every C; every C labelled, the other white keys too when the rows are tall enough
  const bool label_white_keys = row_h_px >= kMinRowForAllLabelsPx;
  for (int midi = lo; midi <= hi; ++midi) {
    const int pitch_class = midi - floor_div(midi, kSemitonesPerOctaveInt) * kSemitonesPerOctaveInt;
    const bool is_c = pitch_class == 0;
    if (is_c) canvas.hline(plot_x0, plot_x1, int(std::lround(y_of(midi - 0.5))), kOctaveLineRgb);
    if (!is_c && (is_black_key(midi) || !label_white_keys)) continue;
    std::string name = std::string(1, kPitchClassLetters[pitch_class]) +
                       std::to_string(floor_div(midi, kSemitonesPerOctaveInt) - kMidiOctaveOffset);
    canvas.text(plot_x0 - kLabelGapPx - Canvas::text_width_px(name), int(std::lround(y_of(midi))) - kGlyphHeightPx / 2,
                name, is_c ? kTextRgb : kFaintTextRgb);
  }

  // note bars, then reversal ticks on top. Where a bar doubles an earlier motor's note (same
  // semitone at the same time) the earlier bar stays and this one is an inset stripe inside it,
  // so a unison shows both colours.
  const int bar_h_px = std::max(kMinBarHeightPx, int(std::lround(row_h_px * kBarFillOfRow)));
  const int inset_px = std::max(kMinInsetPx, int(std::lround(bar_h_px * kInsetOfBar)));
  std::vector<std::pair<int, int>> unison_px;  // [x0, x1) columns shared with earlier motors
  for (size_t m = 0; m < notes.size(); ++m) {
    const Rgb fill = motor_rgb(int(m)), edge = shade(fill, kOutlineShade);
    for (const NoteSegment& n : notes[m]) {
      std::vector<std::pair<uint64_t, uint64_t>> spans;
      for (size_t earlier = 0; earlier < m; ++earlier) append_unison_spans(notes[earlier], n, spans);
      unison_px.clear();
      for (const auto& span : spans)
        unison_px.emplace_back(int(std::lround(x_of(trace.real_seconds(span.first)))),
                               int(std::lround(x_of(trace.real_seconds(span.second)))));
      const int x0 = int(std::lround(x_of(trace.real_seconds(n.start_cycle))));
      const int x1 = std::max(x0 + 1, int(std::lround(x_of(trace.real_seconds(n.end_cycle)))));
      const int yc = int(std::lround(y_of(n.midi_note)));
      const bool outlined = bar_h_px >= kMinOutlinedBarPx && x1 - x0 >= kMinOutlinedBarWidthPx;
      for (int x = x0; x < x1; ++x) {
        int depth = 0;
        for (const auto& span : unison_px) depth += (x >= span.first && x < span.second) ? 1 : 0;
        const int h = std::max(1, bar_h_px - 2 * depth * inset_px);
        const int y0 = yc - h / 2;
        canvas.vline(x, y0, y0 + h, fill);
        if (!outlined || h < kMinOutlinedBarPx) continue;
        if (depth == 0 && (x == x0 || x == x1 - 1)) canvas.vline(x, y0, y0 + h, edge);
        canvas.pixel(x, y0, edge);
        canvas.pixel(x, y0 + h - 1, edge);
      }
    }
  }
  const uint64_t gap_cycles = uint64_t(options.segments.max_gap_s * trace.f_cpu_hz);
  for (size_t m = 0; m < notes.size(); ++m) {
    const std::vector<Step>& steps = trace.motor[m].steps;
    for (size_t i : reversal_indices(steps, gap_cycles)) {
      int x = int(std::lround(x_of(trace.real_seconds(steps[i].rise_cycle))));
      auto it = std::upper_bound(notes[m].begin(), notes[m].end(), i,
                                 [](size_t idx, const NoteSegment& n) { return idx < n.first_step; });
      if (it != notes[m].begin() && std::prev(it)->last_step >= i) {
        int yc = int(std::lround(y_of(std::prev(it)->midi_note)));
        canvas.vline(x, yc - bar_h_px / 2 - kTickOverhangPx, yc - bar_h_px / 2 + bar_h_px + kTickOverhangPx, kReversalRgb);
      } else {  // reversal outside any note: tick on the time axis in the motor's colour
        canvas.vline(x, plot_y1 - 2 * kTickOverhangPx, plot_y1, motor_rgb(int(m)));
      }
    }
  }
  canvas.frame(plot_x0, plot_y0, plot_x1, plot_y1 + 1, kFrameRgb);

  // title and legend
  std::string title = "STEPCHOIR  BOARD " + (trace.board.empty() ? std::string("?") : trace.board) +
                      "   F_CPU " + fixed(trace.f_cpu_hz, 0) + " HZ   CLOCK " +
                      (trace.clock_ppm >= 0 ? "+" : "") + fixed(trace.clock_ppm, 1) + " PPM   " +
                      fixed(end_s, 2) + " S";
  canvas.text(plot_x0, kTitleTopPx, title, kTextRgb);
  int x = plot_x1;
  for (int m = int(trace.motor.size()) - 1; m >= 0; --m) {
    std::string label = "M" + std::to_string(m) + " " + std::to_string(notes[size_t(m)].size()) + " NOTES";
    x -= Canvas::text_width_px(label);
    canvas.text(x, kTitleTopPx, label, kTextRgb);
    x -= kLegendSwatchPx + kLegendSwatchGapPx;
    canvas.fill(x, kTitleTopPx - 1, x + kLegendSwatchPx, kTitleTopPx - 1 + kLegendSwatchPx, motor_rgb(m));
    x -= kLegendGapPx;
  }
  return canvas.take();
}

namespace {

// Closes a FILE* when it goes out of scope.
struct FileCloser {
  // Closes the file.
  void operator()(FILE* f) const {
    if (f) std::fclose(f);
  }
};

}  // namespace

void write_png(const std::string& path, const Image& image) {
  if (image.width_px <= 0 || image.height_px <= 0 ||
      image.rgb.size() != size_t(image.width_px) * size_t(image.height_px) * 3)
    throw std::invalid_argument("write_png: bad image size");
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "wb"));
  if (!file) throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) throw std::runtime_error("write_png: out of memory");
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error("write_png: out of memory");
  }
  std::vector<png_bytep> row_pointers(size_t(image.height_px));
  for (int y = 0; y < image.height_px; ++y)
    row_pointers[size_t(y)] = const_cast<png_bytep>(&image.rgb[size_t(y) * size_t(image.width_px) * 3]);
  if (setjmp(png_jmpbuf(png))) {  // libpng reports errors by longjmp
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(path + ": libpng failed to write");
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, png_uint_32(image.width_px), png_uint_32(image.height_px), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, row_pointers.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(file.get()) != 0) throw std::runtime_error(path + ": write failed");
}

}  // namespace trace
}  // namespace sc

// render_roll.cpp: the piano roll (notes, reversals, grid, labels) and its PNG writer (see render.h).
#include "render.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <utility>

#include "render_canvas.h"

namespace sc {
namespace trace {
namespace {

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

// render_canvas.h: a clipped RGB drawing surface with a 5x7 bitmap font, for the piano roll.
#ifndef STEPCHOIR_TRACE_RENDER_CANVAS_H
#define STEPCHOIR_TRACE_RENDER_CANVAS_H

#include <algorithm>
#include <string>
#include <utility>

#include "render.h"  // Image, Rgb

namespace sc {
namespace trace {

// The glyph for a character ('?' for ones the font lacks): 7 rows of 5 characters, '#' = ink.
const char* glyph_rows(char c);

constexpr int kGlyphWidthPx = 5;
constexpr int kGlyphHeightPx = 7;
constexpr int kGlyphAdvancePx = kGlyphWidthPx + 1;

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

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_RENDER_CANVAS_H

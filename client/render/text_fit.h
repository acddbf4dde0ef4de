#ifndef WAYMARK_CLIENT_RENDER_TEXT_FIT_H_
#define WAYMARK_CLIENT_RENDER_TEXT_FIT_H_

// Text that fits the picture it is drawn in: titles name long sequence folders and carry results,
// and a picture may be as narrow as its map (a camera driving straight ahead). A title too wide is
// shrunk a little, and wrapped at spaces when shrinking is not enough, never cut off.

#include <string>
#include <vector>

namespace waymark::cli {

// The width in pixels of `text` at `font_px`, as the pictures draw it: the larger of the PNG's
// Hershey font (measured with OpenCV) and an estimate for the SVG's sans-serif (0.6 em per
// character, a generous average for Latin text), so that it fits in both.
double TextWidthPx(const std::string& text, double font_px);

struct FittedText {
  double font_px = 0;
  std::vector<std::string> lines;  // at least one
};

// `text` within `max_width_px`: on one line at `font_px` if it fits; else on one line at the
// largest size down to `min_font_px` that fits; else wrapped at spaces at `font_px` (a word wider
// than a line is broken where it must be).
FittedText FitText(const std::string& text, double max_width_px, double font_px,
                   double min_font_px);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_TEXT_FIT_H_

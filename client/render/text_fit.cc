#include "client/render/text_fit.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace waymark::cli {
namespace {

// DrawingToImage's scale for the Hershey simplex font (map_render.cc).
constexpr double kHersheyPxPerScale = 28.0;
constexpr double kSansEmPerChar = 0.6;

bool Fits(const std::string& text, double font_px, double max_width_px) {
  return TextWidthPx(text, font_px) <= max_width_px;
}

// The longest prefix of `word` (at least one character) that fits.
size_t FittingPrefix(const std::string& word, double font_px, double max_width_px) {
  size_t n = word.size();
  while (n > 1 && !Fits(word.substr(0, n), font_px, max_width_px)) --n;
  return n;
}

std::vector<std::string> Words(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  for (char c : text) {
    if (c == ' ') {
      if (!word.empty()) words.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) words.push_back(word);
  return words;
}

std::vector<std::string> Wrap(const std::string& text, double font_px, double max_width_px) {
  std::vector<std::string> lines;
  std::string line;
  for (std::string word : Words(text)) {
    const std::string joined = line.empty() ? word : line + " " + word;
    if (Fits(joined, font_px, max_width_px)) {
      line = joined;
      continue;
    }
    if (!line.empty()) lines.push_back(line);
    line.clear();
    while (!Fits(word, font_px, max_width_px)) {
      const size_t n = FittingPrefix(word, font_px, max_width_px);
      lines.push_back(word.substr(0, n));
      word = word.substr(n);
    }
    line = word;
  }
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

}  // namespace

double TextWidthPx(const std::string& text, double font_px) {
  int baseline = 0;
  const cv::Size hershey =
      cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font_px / kHersheyPxPerScale, 1, &baseline);
  return std::max(static_cast<double>(hershey.width),
                  kSansEmPerChar * font_px * static_cast<double>(text.size()));
}

FittedText FitText(const std::string& text, double max_width_px, double font_px,
                   double min_font_px) {
  if (Fits(text, font_px, max_width_px)) return {font_px, {text}};
  // The size at which it would just fit; widths grow about linearly with the size.
  const double shrunk = font_px * max_width_px / std::max(1.0, TextWidthPx(text, font_px));
  for (double size = std::floor(shrunk * 2) / 2; size >= min_font_px; size -= 0.5) {
    if (Fits(text, size, max_width_px)) return {size, {text}};
  }
  return {font_px, Wrap(text, font_px, max_width_px)};
}

}  // namespace waymark::cli

#include "server/visual_slam/geometry/box_split.h"

#include <cmath>

namespace waymark::visual_slam {
namespace {

bool Usable(const Box& b) {
  return std::isfinite(b.x) && std::isfinite(b.y) && std::isfinite(b.w) && std::isfinite(b.h) &&
         b.w >= 0 && b.h >= 0;
}

}  // namespace

std::vector<bool> InsideAnyBox(const std::vector<cv::Point2f>& pixels,
                               const std::vector<Box>& boxes) {
  std::vector<bool> inside(pixels.size(), false);
  for (const Box& b : boxes) {
    if (!Usable(b)) continue;
    for (size_t i = 0; i < pixels.size(); ++i) {
      const cv::Point2f& p = pixels[i];
      // Comparisons with NaN are false, so a NaN pixel is never inside.
      if (p.x >= b.x && p.x <= b.x + b.w && p.y >= b.y && p.y <= b.y + b.h) inside[i] = true;
    }
  }
  return inside;
}

}  // namespace waymark::visual_slam

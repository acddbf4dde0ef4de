#include "server/crossing/compact_points.h"

#include <algorithm>
#include <cmath>

namespace waymark::crossing {
namespace {

constexpr int kMaxShift = 8;  // 1/256 px: finer than this only costs range

// A coordinate as it can be stored: finite and in [0, 65535].
float InRange(float v) { return std::isfinite(v) ? std::clamp(v, 0.f, 65535.f) : 0.f; }

}  // namespace

CompactPoints::CompactPoints(const std::vector<cv::Point2f>& points) {
  float top = 0;
  for (const cv::Point2f& p : points) top = std::max({top, InRange(p.x), InRange(p.y)});
  int shift = kMaxShift;
  while (shift > 0 && std::lround(std::ldexp(top, shift)) > 65535) --shift;
  step_ = std::ldexp(1.f, -shift);
  xy_.reserve(2 * points.size());
  for (const cv::Point2f& p : points) {
    for (float v : {p.x, p.y}) {
      const long q = std::lround(std::ldexp(InRange(v), shift));
      xy_.push_back(static_cast<uint16_t>(std::min<long>(65535, q)));
    }
  }
}

std::vector<cv::Point2f> CompactPoints::ToVector() const {
  std::vector<cv::Point2f> out(size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = (*this)[i];
  return out;
}

}  // namespace waymark::crossing

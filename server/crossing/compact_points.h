#ifndef WAYMARK_SERVER_CROSSING_COMPACT_POINTS_H_
#define WAYMARK_SERVER_CROSSING_COMPACT_POINTS_H_

// The keypoint positions of a stored view in 4 bytes each where cv::Point2f takes 8 (issue 34:
// beside the descriptors, the positions were 0.07x of a database's memory). Each coordinate is a
// 16-bit multiple of 2^-shift pixels, the finest such step at which the view's largest coordinate
// still fits: 1/128 px at the default 320 x 240 working size, 1/16 px at the largest (4096). A
// position moves by at most half a step, two orders of magnitude below a SIFT keypoint's own
// precision, and the same float positions always give the same stored ones (a reloaded database
// matches exactly as before its restart).

#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace waymark::crossing {

class CompactPoints {
 public:
  CompactPoints() = default;
  // Coordinates that are negative, not finite or past 65535 px are clamped into range.
  explicit CompactPoints(const std::vector<cv::Point2f>& points);

  size_t size() const { return xy_.size() / 2; }
  bool empty() const { return xy_.empty(); }
  cv::Point2f operator[](size_t i) const {
    return {xy_[2 * i] * step_, xy_[2 * i + 1] * step_};
  }
  std::vector<cv::Point2f> ToVector() const;
  size_t memory_bytes() const { return xy_.capacity() * sizeof(uint16_t); }

 private:
  std::vector<uint16_t> xy_;  // x0, y0, x1, y1, ...
  float step_ = 1;            // 2^-shift pixels
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_COMPACT_POINTS_H_

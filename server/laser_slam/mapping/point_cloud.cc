#include "server/laser_slam/mapping/point_cloud.h"

#include <cmath>
#include <cstdint>
#include <vector>

namespace waymark::laser_slam {

PointCloud ScanToPoints(const LaserScan& scan, const Pose2& laser_pose, double min_range,
                        double max_range) {
  PointCloud points;
  points.reserve(scan.ranges.size());
  const double c = std::cos(laser_pose.theta), s = std::sin(laser_pose.theta);
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.ranges[i];
    if (!IsReturn(r, scan.geometry) || r < min_range || r > max_range) continue;
    const double a = scan.geometry.angle_min + static_cast<double>(i) * scan.geometry.angle_increment;
    const double lx = r * std::cos(a), ly = r * std::sin(a);
    points.emplace_back(static_cast<float>(laser_pose.x + c * lx - s * ly),
                        static_cast<float>(laser_pose.y + s * lx + c * ly));
  }
  return points;
}

namespace {

// The cells seen so far: an open-addressing set of cell keys in one array (linear probing, at
// most half full). std::unordered_set allocated a node per point; thinning the local map and the
// loop queries was a tenth of the back end's allocations.
class CellSet {
 public:
  explicit CellSet(size_t expected) {
    size_t capacity = 16;
    while (capacity < 2 * expected) capacity *= 2;
    keys_.assign(capacity, kEmpty);
    shift_ = 64;
    for (size_t c = capacity; c > 1; c /= 2) --shift_;
  }
  // True when `key` was not in the set (it is now).
  bool Insert(std::uint64_t key) {
    if (key == kEmpty) {  // the one key the empty slots cannot hold
      const bool fresh = !has_empty_key_;
      has_empty_key_ = true;
      return fresh;
    }
    const size_t mask = keys_.size() - 1;
    // Fibonacci hashing: the high bits of the product mix both cell indices.
    for (size_t i = static_cast<size_t>((key * 0x9E3779B97F4A7C15ULL) >> shift_);;
         i = (i + 1) & mask) {
      if (keys_[i] == key) return false;
      if (keys_[i] == kEmpty) {
        keys_[i] = key;
        return true;
      }
    }
  }

 private:
  static constexpr std::uint64_t kEmpty = ~0ULL;
  std::vector<std::uint64_t> keys_;
  int shift_ = 60;
  bool has_empty_key_ = false;
};

}  // namespace

PointCloud ThinPoints(const PointCloud& points, double cell) {
  CellSet seen(points.size());
  PointCloud out;
  out.reserve(points.size());
  // A cell index beyond the integers' range is undefined behaviour; the engine's inputs are
  // bounded far below it (input_bounds.h), so such a point is dropped rather than trusted.
  constexpr double kMaxCellIndex = 1e15;
  for (const Eigen::Vector2f& p : points) {
    const double cx = std::floor(p.x() / cell), cy = std::floor(p.y() / cell);
    if (!(std::abs(cx) < kMaxCellIndex && std::abs(cy) < kMaxCellIndex)) continue;
    const auto ix = static_cast<std::int64_t>(cx);
    const auto iy = static_cast<std::int64_t>(cy);
    const std::uint64_t key = (static_cast<std::uint64_t>(ix) << 32) ^
                              (static_cast<std::uint64_t>(iy) & 0xffffffffULL);
    if (seen.Insert(key)) out.push_back(p);
  }
  return out;
}

void AppendTransformed(const PointCloud& points, const Pose2& pose, PointCloud* out) {
  const float c = static_cast<float>(std::cos(pose.theta));
  const float s = static_cast<float>(std::sin(pose.theta));
  const float x = static_cast<float>(pose.x), y = static_cast<float>(pose.y);
  out->reserve(out->size() + points.size());
  for (const Eigen::Vector2f& p : points) {
    out->emplace_back(x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y());
  }
}

PointCloud TransformPoints(const PointCloud& points, const Pose2& pose) {
  PointCloud out;
  AppendTransformed(points, pose, &out);
  return out;
}

}  // namespace waymark::laser_slam

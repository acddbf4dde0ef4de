#include "client/eval/exploration_metrics.h"

#include <algorithm>
#include <cmath>

#include "client/eval/relations_metric.h"  // Compose, Inverse

namespace waymark::cli {

Pose2 FrameTransform::Apply(const Pose2& local) const { return Compose(world_from_frame, local); }

Vec2 FrameTransform::Apply(const Vec2& local) const {
  const Pose2 p = Apply(Pose2{local.x, local.y, 0});
  return {p.x, p.y};
}

SceneSegment FrameTransform::Apply(const SceneSegment& local) const {
  SceneSegment out = local;
  out.a = Apply(local.a);
  out.b = Apply(local.b);
  return out;
}

FrameTransform FrameTransform::MapToWorld(const Pose2& true_pose_at_first_scan) {
  return {true_pose_at_first_scan};
}

FrameTransform FrameTransform::OdometryToWorld(const Pose2& true_pose_at_first_scan,
                                               const Pose2& odometry_at_first_scan) {
  return {Compose(true_pose_at_first_scan, Inverse(odometry_at_first_scan))};
}

double PositionError(const Pose2& truth, const Pose2& estimate) {
  return std::hypot(truth.x - estimate.x, truth.y - estimate.y);
}

double PointSegmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double length2 = dx * dx + dy * dy;
  double t = length2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / length2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

double Completeness(const std::vector<adapters::Wall>& walls,
                    const std::vector<SceneSegment>& mapped, const CompletenessOptions& options) {
  std::vector<SceneSegment> finite;
  for (const SceneSegment& s : mapped) {
    if (std::isfinite(s.a.x) && std::isfinite(s.a.y) && std::isfinite(s.b.x) &&
        std::isfinite(s.b.y)) {
      finite.push_back(s);
    }
  }
  const double step = options.sample_step > 0 ? options.sample_step : 0.02;
  double total = 0, covered = 0;
  for (const adapters::Wall& wall : walls) {
    const double length = std::hypot(wall.x2 - wall.x1, wall.y2 - wall.y1);
    if (!(length > 0)) continue;
    total += length;
    const int pieces = std::max(1, static_cast<int>(std::ceil(length / step)));
    int hits = 0;
    for (int i = 0; i < pieces; ++i) {
      const double t = (i + 0.5) / pieces;
      const Vec2 sample{wall.x1 + t * (wall.x2 - wall.x1), wall.y1 + t * (wall.y2 - wall.y1)};
      // Plain scan over the segments: a few hundred segments times a few thousand samples per
      // call is milliseconds, and the loop calls this once per scan.
      const bool hit = std::any_of(finite.begin(), finite.end(), [&](const SceneSegment& s) {
        return PointSegmentDistance(sample, s.a, s.b) <= options.tolerance;
      });
      hits += hit;
    }
    // Scaled per wall rather than summed per piece, so a fully covered wall adds exactly its
    // length.
    covered += length * hits / pieces;
  }
  return total > 0 ? std::min(1.0, covered / total) : 0.0;
}

}  // namespace waymark::cli

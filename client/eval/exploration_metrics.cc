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

namespace {

std::vector<SceneSegment> FiniteSegments(const std::vector<SceneSegment>& mapped) {
  std::vector<SceneSegment> finite;
  for (const SceneSegment& s : mapped) {
    if (std::isfinite(s.a.x) && std::isfinite(s.a.y) && std::isfinite(s.b.x) &&
        std::isfinite(s.b.y)) {
      finite.push_back(s);
    }
  }
  return finite;
}

// Plain scan over the segments: a few hundred segments times a few thousand samples per call is
// milliseconds, and the exploration loop calls Completeness once per scan.
bool Covered(const Vec2& sample, const std::vector<SceneSegment>& finite, double tolerance) {
  return std::any_of(finite.begin(), finite.end(), [&](const SceneSegment& s) {
    return PointSegmentDistance(sample, s.a, s.b) <= tolerance;
  });
}

}  // namespace

double Completeness(const std::vector<adapters::Wall>& walls,
                    const std::vector<SceneSegment>& mapped, const CompletenessOptions& options) {
  const std::vector<SceneSegment> finite = FiniteSegments(mapped);
  const double step = options.sample_step > 0 ? options.sample_step : 0.02;
  std::vector<int> pieces(walls.size(), 0), hits(walls.size(), 0);
  for (const adapters::WallSample& s : adapters::SampleWalls(walls, step)) {
    ++pieces[s.wall];
    hits[s.wall] += Covered({s.x, s.y}, finite, options.tolerance);
  }
  double total = 0, covered = 0;
  for (size_t k = 0; k < walls.size(); ++k) {
    if (pieces[k] == 0) continue;  // zero length
    const double length = std::hypot(walls[k].x2 - walls[k].x1, walls[k].y2 - walls[k].y1);
    total += length;
    // Scaled per wall rather than summed per piece, so a fully covered wall adds exactly its
    // length.
    covered += length * hits[k] / pieces[k];
  }
  return total > 0 ? std::min(1.0, covered / total) : 0.0;
}

double CompletenessOfVisible(const std::vector<adapters::WallSample>& visible,
                             const std::vector<SceneSegment>& mapped,
                             const CompletenessOptions& options) {
  const std::vector<SceneSegment> finite = FiniteSegments(mapped);
  double total = 0, covered = 0;
  for (const adapters::WallSample& s : visible) {
    total += s.length;
    if (Covered({s.x, s.y}, finite, options.tolerance)) covered += s.length;
  }
  return total > 0 ? std::min(1.0, covered / total) : 0.0;
}

}  // namespace waymark::cli

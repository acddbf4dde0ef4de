#include "server/laser_slam/mapping/map_segments.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

double Length(const MapSegment& s) { return s.right - s.left; }

// Segment b's line seen from a's frame: its offset at a's origin and its direction, with b's
// line covariance carried there (the offset's variance grows with the lever arm).
struct LineInFrame {
  Eigen::Vector2d params;  // (p_y, p_theta)
  Eigen::Matrix2d covariance;
  double from = 0.0, to = 0.0;  // b's extent along a's x axis
};

LineInFrame SeenFrom(const MapSegment& a, const MapSegment& b) {
  const Pose2 rel = Relative(a.frame, b.frame);
  LineInFrame line;
  const double c = std::cos(rel.theta), s = std::sin(rel.theta);
  // b's line y = rel.y + tan(theta) (x - rel.x) at x = 0.
  line.params = Eigen::Vector2d(rel.y - rel.x * s / c, rel.theta);
  // b's p_y is at its own origin, rel.x along the line from a's: moving it costs the angle's
  // uncertainty times that arm.
  Eigen::Matrix2d arm;
  arm << 1.0, -rel.x, 0.0, 1.0;
  line.covariance = arm * b.line_covariance * arm.transpose();
  const double x0 = rel.x + c * b.left, x1 = rel.x + c * b.right;
  line.from = std::min(x0, x1);
  line.to = std::max(x0, x1);
  return line;
}

// The segment a becomes when fused with b (seen from a's frame as `line`).
void Fuse(const MapSegment& b, const LineInFrame& line, MapSegment* a) {
  // Information-weighted mean of the two lines in a's frame; a floor keeps a filter's exact
  // (zero) covariance from dividing by zero.
  const Eigen::Matrix2d floor = Eigen::Vector2d(1e-8, 1e-10).asDiagonal();
  const Eigen::Matrix2d ia = (a->line_covariance + floor).inverse();
  const Eigen::Matrix2d ib = (line.covariance + floor).inverse();
  const Eigen::Matrix2d covariance = (ia + ib).inverse();
  const Eigen::Vector2d fused = covariance * (ib * line.params);
  const double left = std::min(a->left, line.from), right = std::max(a->right, line.to);
  if (line.from < a->left) {
    a->left_type = b.left_type;
    a->left_variance = b.left_variance;
  }
  if (line.to > a->right) {
    a->right_type = b.right_type;
    a->right_variance = b.right_variance;
  }
  a->frame = Compose(a->frame, Pose2{0.0, fused(0), fused(1)});
  // Back to the midpoint, as the filter keeps its frames (the angle's lever arm stays short).
  const double middle = 0.5 * (left + right);
  a->frame = Compose(a->frame, Pose2{middle, 0.0, 0.0});
  Eigen::Matrix2d arm;
  arm << 1.0, middle, 0.0, 1.0;
  a->line_covariance = arm * covariance * arm.transpose();
  a->left = left - middle;
  a->right = right - middle;
  a->observations += b.observations;
  a->last_seen_scan = std::max(a->last_seen_scan, b.last_seen_scan);
  a->active = a->active || b.active;
}

}  // namespace

MapSegment SegmentInMapFrame(const MapSegment& segment, const Pose2& origin,
                             const std::vector<OriginSample>& samples,
                             double stamp_of_last_sighting) {
  MapSegment placed = segment;
  const Pose2 at = samples.empty() ? origin : OriginAt(samples, stamp_of_last_sighting);
  placed.frame = Compose(at, segment.frame);
  return placed;
}

std::vector<MapSegment> SegmentsInMapFrame(const TiedTrajectory& trajectory,
                                           const std::vector<MapSegment>& segments) {
  return SegmentsInMapFrame(trajectory, segments, CurrentOrigins(trajectory));
}

std::vector<MapSegment> SegmentsInMapFrame(const TiedTrajectory& trajectory,
                                           const std::vector<MapSegment>& segments,
                                           const std::vector<OriginSample>& samples) {
  std::vector<MapSegment> placed;
  placed.reserve(segments.size());
  for (const MapSegment& segment : segments) {
    // The node at or before the last sighting (nodes oldest first, by scan), else the first.
    const auto after = std::upper_bound(
        trajectory.nodes.begin(), trajectory.nodes.end(), segment.last_seen_scan,
        [](std::uint64_t scan, const NodeView& node) { return scan < node.scan; });
    const double stamp = trajectory.nodes.empty() ? 0.0
                         : after == trajectory.nodes.begin() ? after->stamp
                                                             : std::prev(after)->stamp;
    placed.push_back(SegmentInMapFrame(segment, trajectory.origin, samples, stamp));
  }
  return placed;
}

MergedSegments MergeTrajectorySegments(std::vector<PlacedSegment> segments,
                                       const MapSegmentsOptions& options) {
  // Longest first: a long wall collects the pieces the other robots saw of it.
  std::stable_sort(segments.begin(), segments.end(),
                   [](const PlacedSegment& a, const PlacedSegment& b) {
                     return Length(a.segment) > Length(b.segment);
                   });
  const Eigen::Matrix2d placement =
      Eigen::Vector2d(options.placement_sigma_xy * options.placement_sigma_xy,
                      options.placement_sigma_theta * options.placement_sigma_theta)
          .asDiagonal();
  // Chi-square with 2 degrees of freedom: P(d2 > x) = exp(-x / 2).
  const double gate = -2.0 * std::log(1.0 - options.gate_probability);
  MergedSegments out;
  for (const PlacedSegment& candidate : segments) {
    int best = -1;
    double best_d2 = gate;
    LineInFrame best_line;
    MapSegment best_b;
    for (size_t k = 0; k < out.segments.size(); ++k) {
      const std::vector<int>& held = out.trajectories[k];
      if (std::find(held.begin(), held.end(), candidate.trajectory) != held.end()) continue;
      const MapSegment& a = out.segments[k];
      MapSegment b = candidate.segment;
      // Lines are undirected: compare b described the way a runs.
      if (std::abs(NormalizeAngle(b.frame.theta - a.frame.theta)) > M_PI / 2) b = Flipped(b);
      const LineInFrame line = SeenFrom(a, b);
      if (!(std::abs(line.params(1)) < M_PI / 4)) continue;
      // Overlapping along the line: a doorway's gap keeps two walls apart.
      if (!(std::min(a.right, line.to) > std::max(a.left, line.from))) continue;
      const Eigen::Matrix2d covariance = a.line_covariance + line.covariance + 2.0 * placement;
      const Eigen::LDLT<Eigen::Matrix2d> solver(covariance);
      if (solver.info() != Eigen::Success) continue;
      const double d2 = line.params.dot(solver.solve(line.params));
      if (d2 < best_d2) {
        best = static_cast<int>(k);
        best_d2 = d2;
        best_line = line;
        best_b = b;
      }
    }
    if (best < 0) {
      out.segments.push_back(candidate.segment);
      out.trajectories.push_back({candidate.trajectory});
      continue;
    }
    Fuse(best_b, best_line, &out.segments[best]);
    out.trajectories[best].push_back(candidate.trajectory);
    ++out.fused;
  }
  return out;
}

}  // namespace waymark::laser_slam

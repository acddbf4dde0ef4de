#include "server/laser_slam/exploration/observation_prediction.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

// How much further than the predicted map range a point may lie and still count as seen: the point
// being tested may itself lie on a mapped segment.
constexpr double kOcclusionTolerance = 0.05;

Eigen::Vector2d PointOn(const MapSegment& s, double along) {
  const Pose2 p = Compose(s.frame, Pose2{along, 0.0, 0.0});
  return Eigen::Vector2d(p.x, p.y);
}

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

MapTotals Totals(const std::vector<MapSegment>& segments) {
  MapTotals totals;
  for (const MapSegment& s : segments) {
    totals.length += s.right - s.left;
    ++totals.segments;
    totals.real_endpoints += (s.left_type == EndpointType::kReal) + (s.right_type == EndpointType::kReal);
  }
  return totals;
}

ObservationPredictor::ObservationPredictor(const ExplorationView& view,
                                           const ExplorationOptions& options, double travel)
    : options_(options),
      beams_(view.scan.geometry),
      laser_pose_(view.laser_pose),
      max_range_(view.max_range),
      min_incidence_sin_(std::sin(view.min_incidence)) {
  const Eigen::Vector2d robot(view.robot.x, view.robot.y);
  const double horizon = view.max_range + travel;
  struct Line {
    Eigen::Vector2d a, b;
  };
  std::vector<Line> near;
  for (const MapSegment& s : view.segments) {
    const Eigen::Vector2d a = PointOn(s, s.left), b = PointOn(s, s.right);
    if (PointSegmentDistance(robot, a, b) > horizon) continue;
    occluders_.emplace_back(a, b);
    near.push_back({a, b});
  }
  const double min_cross = std::sin(options.corner_angle);
  for (const MapSegment& s : view.segments) {
    const Eigen::Vector2d a = PointOn(s, s.left), b = PointOn(s, s.right);
    const double length = (b - a).norm();
    if (length <= 0.0) continue;
    const Eigen::Vector2d along = (b - a) / length;
    for (int end = 0; end < 2; ++end) {
      const bool virtual_end =
          (end == 0 ? s.left_type : s.right_type) == EndpointType::kVirtual;
      Frontier f;
      f.endpoint = end == 0 ? a : b;
      if (!virtual_end || (f.endpoint - robot).norm() > horizon) continue;
      f.outward = end == 0 ? Eigen::Vector2d(-along) : along;
      f.back = std::min(0.2, 0.5 * length);
      f.reach = view.max_range;
      // The nearest mapped line crossing ours just past this endpoint: a predicted corner.
      for (const Line& other : near) {
        const Eigen::Vector2d w = other.b - other.a;
        const double w_length = w.norm();
        if (w_length <= 0.0) continue;
        const double cross = Cross(f.outward, w / w_length);
        if (std::abs(cross) < min_cross) continue;
        // endpoint + s * outward = other.a + t * w
        const Eigen::Vector2d d = other.a - f.endpoint;
        const double s_at = Cross(d, w) / Cross(f.outward, w);
        if (s_at < -options.adjacency || s_at > options.corner_reach) continue;
        const Eigen::Vector2d crossing = f.endpoint + s_at * f.outward;
        if (PointSegmentDistance(crossing, other.a, other.b) > options.corner_reach) continue;
        if (!f.corner || std::max(0.0, s_at) < f.reach) {
          f.corner = true;
          f.reach = std::max(0.0, s_at);
        }
      }
      frontiers_.push_back(f);
    }
  }
  // What the laser sees past each frontier from where the robot stands now. The map does not
  // have it although the last scan was taken here, so it is not wall (the wall ended where the
  // range or an opening cut it): only what a move adds beyond it counts as gain.
  const Pose2 laser = Compose(view.robot, laser_pose_);
  const std::vector<double> ranges = CastMap(laser);
  for (const Frontier& f : frontiers_) seen_now_.push_back(RunOf(f, laser, ranges));
}

std::vector<double> ObservationPredictor::CastMap(const Pose2& laser) const {
  std::vector<double> ranges(beams_.beam_count, std::numeric_limits<double>::infinity());
  const Eigen::Vector2d origin(laser.x, laser.y);
  for (int i = 0; i < beams_.beam_count; ++i) {
    const double angle = laser.theta + beams_.angle_min + i * beams_.angle_increment;
    const Eigen::Vector2d ray(std::cos(angle), std::sin(angle));
    for (const auto& [a, b] : occluders_) {
      const Eigen::Vector2d ab = b - a;
      const double denom = Cross(ray, ab);
      if (std::abs(denom) < 1e-12) continue;
      const Eigen::Vector2d ao = a - origin;
      const double t = Cross(ao, ab) / denom;  // along the ray
      const double u = Cross(ao, ray) / denom;  // along the segment
      if (t > 0.0 && u >= 0.0 && u <= 1.0) ranges[i] = std::min(ranges[i], t);
    }
  }
  return ranges;
}

bool ObservationPredictor::Visible(const Pose2& laser, const std::vector<double>& ranges,
                                   const Eigen::Vector2d& point,
                                   const Eigen::Vector2d& line_direction) const {
  const Eigen::Vector2d d = point - Eigen::Vector2d(laser.x, laser.y);
  const double distance = d.norm();
  if (distance > max_range_ || distance < 1e-6) return false;
  if (std::abs(Cross(d / distance, line_direction)) < min_incidence_sin_) return false;
  const double bearing = NormalizeAngle(std::atan2(d.y(), d.x()) - laser.theta);
  const double index = (bearing - beams_.angle_min) / beams_.angle_increment;
  if (index < -0.5 || index > beams_.beam_count - 0.5) return false;
  const int beam = std::clamp(static_cast<int>(std::lround(index)), 0, beams_.beam_count - 1);
  return distance <= ranges[beam] + kOcclusionTolerance;
}

ObservationPredictor::Run ObservationPredictor::RunOf(const Frontier& f, const Pose2& laser,
                                                     const std::vector<double>& ranges) const {
  Run run;
  // The observation must also cover the mapped segment at this end, or it would not match it.
  if (!Visible(laser, ranges, f.endpoint - f.back * f.outward, f.outward) ||
      !Visible(laser, ranges, f.endpoint, f.outward)) {
    return run;
  }
  // Samples every sample_step out to the reach, the last one exactly at it (at the corner).
  const int samples = std::max(1, static_cast<int>(std::ceil(f.reach / options_.sample_step - 1e-9)));
  bool reached = true;
  for (int k = 1; k <= samples; ++k) {
    const double s = std::min(f.reach, k * options_.sample_step);
    if (!Visible(laser, ranges, f.endpoint + s * f.outward, f.outward)) {
      reached = false;
      break;
    }
    run.length = s;
  }
  if (f.corner && reached) {
    run.corner = true;
    run.length = f.reach;
  }
  return run;
}

ExplorationGain ObservationPredictor::Predict(const Pose2& robot) const {
  ExplorationGain gain;
  if (frontiers_.empty() || beams_.beam_count < 2) return gain;
  const Pose2 laser = Compose(robot, laser_pose_);
  const std::vector<double> ranges = CastMap(laser);
  for (size_t i = 0; i < frontiers_.size(); ++i) {
    const Run run = RunOf(frontiers_[i], laser, ranges);
    const Run& now = seen_now_[i];
    if (run.corner && !now.corner) ++gain.new_real_endpoints;
    const double extension = run.length - now.length;
    if (extension >= options_.min_extension) gain.extension += extension;
  }
  return gain;
}

}  // namespace waymark::laser_slam

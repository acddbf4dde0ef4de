#include "client/cli/map_frame.h"

#include <cmath>
#include <map>
#include <vector>

namespace waymark::cli {

std::vector<v1::MapOriginSample> CurrentOriginSamples(const v1::MapTrajectory& t,
                                                      const v1::Trajectory& poses) {
  std::map<double, v1::Pose2D> by_stamp;
  for (const v1::TrajectoryPose& pose : poses.poses()) {
    if (pose.has_pose()) by_stamp[pose.stamp()] = pose.pose();
  }
  // The server's origins at every node (a pose graph of the trajectory's nodes) where it sent
  // them, else the follow's samples, interpolated.
  const auto& source = t.node_origins().empty() ? t.origin_samples() : t.node_origins();
  std::vector<v1::MapOriginSample> out(source.begin(), source.end());
  for (v1::MapOriginSample& sample : out) {
    if (!sample.has_map_pose()) continue;
    const auto it = by_stamp.lower_bound(sample.stamp() - 1e-6);
    if (it == by_stamp.end() || std::abs(it->first - sample.stamp()) > 1e-6) continue;
    // origin = map_pose (-) pose
    const v1::Pose2D& m = sample.map_pose();
    const v1::Pose2D& p = it->second;
    const double theta = std::remainder(m.theta() - p.theta(), 2 * M_PI);
    const double c = std::cos(theta), s = std::sin(theta);
    v1::Pose2D* origin = sample.mutable_origin();
    origin->set_theta(theta);
    origin->set_x(m.x() - (c * p.x() - s * p.y()));
    origin->set_y(m.y() - (s * p.x() + c * p.y()));
  }
  return out;
}

v1::Pose2D OriginAt(const v1::MapTrajectory& t, const std::vector<v1::MapOriginSample>& samples,
                    double stamp) {
  if (samples.empty()) return t.origin();
  if (stamp <= samples[0].stamp()) return samples[0].origin();
  for (size_t i = 1; i < samples.size(); ++i) {
    if (stamp > samples[i].stamp()) continue;
    const v1::Pose2D& a = samples[i - 1].origin();
    const v1::Pose2D& b = samples[i].origin();
    const double span = samples[i].stamp() - samples[i - 1].stamp();
    const double f = span > 0 ? (stamp - samples[i - 1].stamp()) / span : 1.0;
    v1::Pose2D out;
    out.set_x(a.x() + f * (b.x() - a.x()));
    out.set_y(a.y() + f * (b.y() - a.y()));
    out.set_theta(
        std::remainder(a.theta() + f * std::remainder(b.theta() - a.theta(), 2 * M_PI), 2 * M_PI));
    return out;
  }
  return samples.back().origin();
}

void MoveToMapFrame(const v1::MapTrajectory& t, v1::Trajectory* trajectory) {
  const std::vector<v1::MapOriginSample> samples = CurrentOriginSamples(t, *trajectory);
  for (v1::TrajectoryPose& pose : *trajectory->mutable_poses()) {
    if (!pose.has_pose()) continue;
    const v1::Pose2D origin = OriginAt(t, samples, pose.stamp());
    const double c = std::cos(origin.theta()), s = std::sin(origin.theta());
    v1::Pose2D* p = pose.mutable_pose();
    const double x = p->x(), y = p->y();
    p->set_x(origin.x() + c * x - s * y);
    p->set_y(origin.y() + s * x + c * y);
    p->set_theta(std::remainder(p->theta() + origin.theta(), 2 * M_PI));
  }
}

}  // namespace waymark::cli

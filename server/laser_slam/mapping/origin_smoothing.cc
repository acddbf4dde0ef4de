#include "server/laser_slam/mapping/origin_smoothing.h"

#include <algorithm>
#include <cmath>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/mapping_options.h"
#include "server/laser_slam/mapping/pose_graph.h"

namespace waymark::laser_slam {

// The session graph's default chain sigmas where a node has none of its own.
Eigen::Vector3d ChainStepSigma(const NodeView& node, const Pose2& step) {
  if (node.step_sigma.minCoeff() > 0.0) return node.step_sigma;
  static const MappingOptions kDefaults;
  const double distance = std::hypot(step.x, step.y);
  const double xy = kDefaults.chain_sigma_xy + kDefaults.chain_sigma_xy_per_m * distance;
  return Eigen::Vector3d(xy, xy,
                         kDefaults.chain_sigma_theta + kDefaults.chain_sigma_theta_per_m * distance +
                             kDefaults.chain_sigma_theta_per_rad * std::abs(step.theta));
}

void AppendChain(const std::vector<NodeView>& nodes, int first_pose,
                 std::vector<GraphConstraint>* constraints) {
  for (size_t i = 1; i < nodes.size(); ++i) {
    GraphConstraint chain;
    chain.kind = GraphConstraint::Kind::kChain;
    chain.from = first_pose + static_cast<int>(i) - 1;
    chain.to = first_pose + static_cast<int>(i);
    chain.relative = Relative(nodes[i - 1].global, nodes[i].global);
    chain.sigma = ChainStepSigma(nodes[i], chain.relative);
    constraints->push_back(chain);
  }
}

int NodeOfScan(const std::vector<NodeView>& nodes, std::uint64_t scan) {
  const auto it = std::lower_bound(
      nodes.begin(), nodes.end(), scan,
      [](const NodeView& node, std::uint64_t s) { return node.scan < s; });
  return it == nodes.end() || it->scan != scan ? -1 : static_cast<int>(it - nodes.begin());
}

Pose2 ObservedMapPose(const OriginSample& sample, const NodeView& node) {
  return sample.matched ? sample.map_pose : Compose(sample.origin, node.global);
}

OriginSample PlacedNode(const NodeView& node, const Pose2& map_pose) {
  OriginSample sample;
  sample.scan = node.scan;
  sample.stamp = node.stamp;
  sample.matched = true;
  sample.map_pose = map_pose;
  sample.origin = Compose(map_pose, Invert(node.global));
  return sample;
}

std::vector<OriginSample> SmoothOrigins(const std::vector<NodeView>& nodes,
                                        const std::vector<OriginSample>& samples,
                                        const OriginSmoothingOptions& options) {
  std::vector<OriginSample> refreshed = samples;
  RefreshOrigins(nodes, &refreshed);
  if (nodes.empty() || samples.empty()) return refreshed;

  // Pose 0 is the map's frame (held fixed); node i is pose i + 1, started where the
  // interpolated origins put it.
  const int n = static_cast<int>(nodes.size());
  std::vector<Pose2> poses(static_cast<size_t>(n) + 1);
  for (int i = 0; i < n; ++i) {
    poses[i + 1] = Compose(OriginAt(refreshed, nodes[i].stamp), nodes[i].global);
  }
  std::vector<GraphConstraint> constraints;
  constraints.reserve(static_cast<size_t>(n) + samples.size());
  AppendChain(nodes, 1, &constraints);
  int observed = 0;
  for (const OriginSample& sample : refreshed) {
    const int node = NodeOfScan(nodes, sample.scan);
    if (node < 0) continue;
    GraphConstraint seen;
    seen.kind = GraphConstraint::Kind::kLoop;  // under the Huber loss, as a closure
    seen.from = 0;
    seen.to = node + 1;
    seen.relative = ObservedMapPose(sample, nodes[node]);
    seen.sigma = options.sample_sigma();
    constraints.push_back(seen);
    ++observed;
  }
  if (observed == 0) return refreshed;

  GraphSolveOptions solve;
  solve.huber_scale = options.huber_scale;
  solve.max_iterations = options.max_iterations;
  SolvePoseGraph(poses, constraints, solve);

  std::vector<OriginSample> smoothed;
  smoothed.reserve(nodes.size());
  for (int i = 0; i < n; ++i) {
    const Pose2& map_pose = poses[i + 1];
    if (!(std::isfinite(map_pose.x) && std::isfinite(map_pose.y) &&
          std::isfinite(map_pose.theta))) {
      return refreshed;  // the solver gave up: the samples as they were
    }
    smoothed.push_back(PlacedNode(nodes[i], map_pose));
  }
  return smoothed;
}

}  // namespace waymark::laser_slam

#include "server/laser_slam/mapping/map_graph.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/pose_cells.h"
#include "server/laser_slam/mapping/pose_graph.h"

namespace waymark::laser_slam {
namespace {

bool Finite(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

}  // namespace

std::vector<std::vector<OriginSample>> SolveMapGraph(const std::vector<TiedTrajectory>& trajectories,
                                                     const MapGraphOptions& options) {
  // Where the one-at-a-time placement has every node: the start, and what the samples were
  // matched against. Trajectory t's node i is pose first_pose[t] + i.
  std::vector<int> first_pose;
  std::vector<Pose2> poses;
  std::vector<int> owner;
  for (size_t t = 0; t < trajectories.size(); ++t) {
    first_pose.push_back(static_cast<int>(poses.size()));
    for (const NodeView& node : NodesInMapFrame(trajectories[t])) {
      poses.push_back(node.global);
      owner.push_back(static_cast<int>(t));
    }
  }
  // Every node at `at` (its pose index).
  const auto placed_at = [&](const std::vector<Pose2>& at) {
    std::vector<std::vector<OriginSample>> out(trajectories.size());
    for (size_t t = 0; t < trajectories.size(); ++t) {
      const std::vector<NodeView>& nodes = trajectories[t].nodes;
      out[t].reserve(nodes.size());
      for (size_t i = 0; i < nodes.size(); ++i) {
        out[t].push_back(PlacedNode(nodes[i], at[first_pose[t] + static_cast<int>(i)]));
      }
    }
    return out;
  };
  if (trajectories.empty() || trajectories.front().nodes.empty()) return placed_at(poses);

  const PoseCells cells(poses, owner, std::max(options.anchor_radius, 1e-3));
  std::vector<GraphConstraint> constraints;
  int anchored = 0;
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const std::vector<NodeView>& nodes = trajectories[t].nodes;
    AppendChain(nodes, first_pose[t], &constraints);
    // Its own loop closures, at the relative poses its session's graph now gives them: with no
    // sample pulling, the trajectory keeps its shape, as stiff as its closures make it. Its own
    // session accepted them (and switched off the ones its graph contradicted), so they are held
    // as its chain is, not under the Huber loss the samples from other robots' maps are under.
    for (const GraphConstraint& loop : LoopsInForce(trajectories[t])) {
      GraphConstraint held = loop;
      held.kind = GraphConstraint::Kind::kChain;
      held.from = first_pose[t] + loop.from;
      held.to = first_pose[t] + loop.to;
      held.relative = Relative(nodes[loop.from].global, nodes[loop.to].global);
      constraints.push_back(held);
    }
    bool observed_once = false;
    for (const OriginSample& sample : trajectories[t].samples) {
      const int node = NodeOfScan(nodes, sample.scan);
      if (node < 0) continue;
      observed_once = true;
      const Pose2 observed = ObservedMapPose(sample, nodes[node]);
      // Relative to the nearest other node as the follow saw it; with none near, to the gauge
      // node (the map frame, which does not move).
      const int anchor = std::max(cells.NearestOther(static_cast<int>(t), observed), 0);
      GraphConstraint seen;
      seen.kind = GraphConstraint::Kind::kLoop;  // under the Huber loss, as a closure
      seen.from = anchor;
      seen.to = first_pose[t] + node;
      seen.relative = Relative(poses[anchor], observed);
      seen.sigma = options.samples.sample_sigma();
      constraints.push_back(seen);
      ++anchored;
    }
    if (!observed_once && t > 0 && !nodes.empty()) {
      // Tied in and not followed (or its samples on pruned nodes only): held by its origin, as
      // rigid as the one-at-a-time placement holds it.
      GraphConstraint held;
      held.kind = GraphConstraint::Kind::kChain;
      held.from = 0;
      held.to = first_pose[t];
      held.relative = Relative(poses[0], poses[first_pose[t]]);
      held.sigma = options.samples.sample_sigma();
      constraints.push_back(held);
    }
  }
  if (anchored == 0) return placed_at(poses);

  // Pose 0 (the map frame's first node) is the gauge and stays where it is.
  GraphSolveOptions solve;
  solve.huber_scale = options.samples.huber_scale;
  solve.max_iterations = options.samples.max_iterations;
  std::vector<Pose2> solved = poses;
  SolvePoseGraph(solved, constraints, solve);
  for (const Pose2& p : solved) {
    if (!Finite(p)) return placed_at(poses);  // the solver gave up: as placed one at a time
  }
  return placed_at(solved);
}

}  // namespace waymark::laser_slam

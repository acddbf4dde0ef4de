#include "server/laser_slam/mapping/map_graph.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/pose_graph.h"

namespace waymark::laser_slam {
namespace {

struct NodeRef {
  int trajectory = -1;
  int pose = -1;  // index in the graph's poses
};

// The nodes in square cells of the anchor radius, so that the nearest node within it is among
// the 3 x 3 cells around a point (a map revisited for hours holds tens of thousands of nodes and
// as many samples).
class NodeCells {
 public:
  NodeCells(const std::vector<std::vector<NodeView>>& placed, const std::vector<int>& first_pose,
            double radius)
      : placed_(placed), first_pose_(first_pose), radius_(radius) {
    for (size_t t = 0; t < placed.size(); ++t) {
      for (size_t i = 0; i < placed[t].size(); ++i) {
        cells_[Key(placed[t][i].global.x, placed[t][i].global.y)].push_back(
            NodeRef{static_cast<int>(t), static_cast<int>(i)});
      }
    }
  }

  // The nearest node of a trajectory other than `self` to `at` within the radius, by where the
  // one-at-a-time placement has it (pose -1: none).
  NodeRef NearestOther(int self, const Pose2& at) const {
    NodeRef best;
    double best_sq = radius_ * radius_;
    const auto [cx, cy] = Cell(at.x, at.y);
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(Pack(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (const NodeRef& ref : it->second) {
          if (ref.trajectory == self) continue;
          const Pose2& p = placed_[ref.trajectory][ref.pose].global;
          const double sq = (p.x - at.x) * (p.x - at.x) + (p.y - at.y) * (p.y - at.y);
          if (sq <= best_sq) {
            best_sq = sq;
            best = NodeRef{ref.trajectory, first_pose_[ref.trajectory] + ref.pose};
          }
        }
      }
    }
    return best;
  }

 private:
  std::pair<std::int64_t, std::int64_t> Cell(double x, double y) const {
    return {static_cast<std::int64_t>(std::floor(x / radius_)),
            static_cast<std::int64_t>(std::floor(y / radius_))};
  }
  static std::uint64_t Pack(std::int64_t cx, std::int64_t cy) {
    return (static_cast<std::uint64_t>(cx) << 32) ^ (static_cast<std::uint64_t>(cy) & 0xffffffffu);
  }
  std::uint64_t Key(double x, double y) const {
    const auto [cx, cy] = Cell(x, y);
    return Pack(cx, cy);
  }

  const std::vector<std::vector<NodeView>>& placed_;
  const std::vector<int>& first_pose_;
  const double radius_;
  std::unordered_map<std::uint64_t, std::vector<NodeRef>> cells_;  // NodeRef::pose: node index
};

bool Finite(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

}  // namespace

std::vector<std::vector<OriginSample>> SolveMapGraph(const std::vector<TiedTrajectory>& trajectories,
                                                     const MapGraphOptions& options) {
  // Where the one-at-a-time placement has every node: the start, and what the samples were
  // matched against.
  std::vector<std::vector<NodeView>> placed;
  std::vector<int> first_pose;
  std::vector<Pose2> poses;
  for (const TiedTrajectory& trajectory : trajectories) {
    placed.push_back(NodesInMapFrame(trajectory));
    first_pose.push_back(static_cast<int>(poses.size()));
    for (const NodeView& node : placed.back()) poses.push_back(node.global);
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
  if (trajectories.empty() || placed.front().empty()) return placed_at(poses);

  const NodeCells cells(placed, first_pose, std::max(options.anchor_radius, 1e-3));
  std::vector<GraphConstraint> constraints;
  int anchored = 0;
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const std::vector<NodeView>& nodes = trajectories[t].nodes;
    for (size_t i = 1; i < nodes.size(); ++i) {
      GraphConstraint chain;
      chain.kind = GraphConstraint::Kind::kChain;
      chain.from = first_pose[t] + static_cast<int>(i) - 1;
      chain.to = first_pose[t] + static_cast<int>(i);
      chain.relative = Relative(nodes[i - 1].global, nodes[i].global);
      chain.sigma = ChainStepSigma(nodes[i], chain.relative);
      constraints.push_back(chain);
    }
    // Its own loop closures, at the relative poses its session's graph now gives them: with no
    // sample pulling, the trajectory keeps its shape, as stiff as its closures make it. Its own
    // session accepted them (and switched off the ones its graph contradicted), so they are held
    // as its chain is, not under the Huber loss the samples from other robots' maps are under.
    for (const GraphConstraint& loop : trajectories[t].loops) {
      if (loop.from < 0 || loop.to < 0 || loop.from >= static_cast<int>(nodes.size()) ||
          loop.to >= static_cast<int>(nodes.size()) || !loop.enabled) {
        continue;
      }
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
      NodeRef anchor = cells.NearestOther(static_cast<int>(t), observed);
      if (anchor.pose < 0) anchor.pose = 0;
      GraphConstraint seen;
      seen.kind = GraphConstraint::Kind::kLoop;  // under the Huber loss, as a closure
      seen.from = anchor.pose;
      seen.to = first_pose[t] + node;
      seen.relative = Relative(poses[anchor.pose], observed);
      seen.sigma = Eigen::Vector3d(options.samples.sample_sigma_xy,
                                   options.samples.sample_sigma_xy,
                                   options.samples.sample_sigma_theta);
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
      held.sigma = Eigen::Vector3d(options.samples.sample_sigma_xy,
                                   options.samples.sample_sigma_xy,
                                   options.samples.sample_sigma_theta);
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

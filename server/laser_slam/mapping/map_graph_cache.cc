#include "server/laser_slam/mapping/map_graph_cache.h"

#include <cstring>
#include <utility>

namespace waymark::laser_slam {
namespace {

void Put(const Pose2& p, std::vector<double>* out) {
  out->insert(out->end(), {p.x, p.y, p.theta});
}

void Put(const Eigen::Vector3d& v, std::vector<double>* out) {
  out->insert(out->end(), {v.x(), v.y(), v.z()});
}

// Bit for bit, so that a NaN equals itself and -0 differs from 0: the same bits give the same
// solution, and nothing else is assumed.
bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// Every input SolveMapGraph reads, flattened in a fixed order (counts included, so that two
// different sets of trajectories never flatten alike).
std::vector<double> GraphInputs(const std::vector<TiedTrajectory>& trajectories) {
  std::vector<double> out;
  out.push_back(static_cast<double>(trajectories.size()));
  for (const TiedTrajectory& t : trajectories) {
    Put(t.origin, &out);
    out.push_back(static_cast<double>(t.nodes.size()));
    for (const NodeView& node : t.nodes) {
      out.insert(out.end(), {static_cast<double>(node.scan), node.stamp});
      Put(node.global, &out);
      Put(node.step_sigma, &out);
    }
    out.push_back(static_cast<double>(t.samples.size()));
    for (const OriginSample& s : t.samples) {
      out.insert(out.end(), {static_cast<double>(s.scan), s.stamp, s.matched ? 1.0 : 0.0});
      Put(s.origin, &out);
      Put(s.map_pose, &out);
    }
    out.push_back(static_cast<double>(t.loops.size()));
    for (const GraphConstraint& c : t.loops) {
      out.insert(out.end(), {static_cast<double>(c.kind), static_cast<double>(c.from),
                             static_cast<double>(c.to), c.enabled ? 1.0 : 0.0, c.score});
      Put(c.relative, &out);
      Put(c.sigma, &out);
    }
  }
  return out;
}

}  // namespace

std::vector<std::vector<OriginSample>> MapGraphCache::Solve(
    const std::vector<TiedTrajectory>& trajectories) {
  std::vector<double> inputs = GraphInputs(trajectories);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (kept_ && SameBits(inputs, inputs_)) {
      ++stats_.reused;
      return solution_;
    }
  }
  // Solved outside the lock: a read of an unchanged map need not wait for another's solve.
  std::vector<std::vector<OriginSample>> solution = SolveMapGraph(trajectories, options_);
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.solved;
  inputs_ = std::move(inputs);
  solution_ = solution;
  kept_ = true;
  return solution;
}

MapGraphCache::Stats MapGraphCache::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace waymark::laser_slam

#include "server/laser_slam/mapping/closure_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace waymark::laser_slam {
namespace {

struct Edge {
  int to = 0;
  double xy2 = 0.0;     // position variance of the edge itself
  double theta2 = 0.0;  // heading variance
  int pivot = 0;        // the node its heading error turns about
};

// The submap holding node `node` (the last whose first node is at or before it), or -1.
int SubmapOf(const std::vector<SubmapSpan>& submaps, int node) {
  const auto it = std::upper_bound(submaps.begin(), submaps.end(), node,
                                   [](int n, const SubmapSpan& s) { return n < s.first; });
  if (it == submaps.begin()) return -1;
  return static_cast<int>(it - submaps.begin()) - 1;
}

}  // namespace

std::vector<ChainUncertainty::Sigma> UncertaintyToSubmaps(const ChainUncertainty& chain,
                                                          const std::vector<SubmapSpan>& submaps,
                                                          const std::vector<ClosureTie>& closures,
                                                          int index) {
  const int count = static_cast<int>(submaps.size());
  std::vector<ChainUncertainty::Sigma> out(count);
  if (count == 0 || index < 0 || index >= chain.size()) return out;
  std::vector<std::vector<Edge>> edges(count);
  const auto add = [&](int a, int b, double xy2, double theta2, int pivot) {
    edges[a].push_back({b, xy2, theta2, pivot});
    edges[b].push_back({a, xy2, theta2, pivot});
  };
  for (int s = 0; s + 1 < count; ++s) {
    if (submaps[s + 1].first > index) break;
    const ChainUncertainty::Sigma c = chain.Between(submaps[s].first, submaps[s + 1].first);
    add(s, s + 1, c.xy * c.xy, c.theta * c.theta, submaps[s].first);
  }
  for (const ClosureTie& tie : closures) {
    if (tie.node > index || tie.submap < 0 || tie.submap >= count) continue;
    const int from = SubmapOf(submaps, tie.node);
    if (from < 0 || from == tie.submap) continue;
    const ChainUncertainty::Sigma inside = chain.Between(submaps[from].first, tie.node);
    const double xy = std::max(tie.sigma(0), tie.sigma(1));
    add(from, tie.submap, inside.xy * inside.xy + xy * xy,
        inside.theta * inside.theta + tie.sigma(2) * tie.sigma(2), tie.node);
  }
  // Shortest paths from the robot's own submap, in position variance.
  const Eigen::Vector2d here = chain.Position(index);
  std::vector<double> xy2(count, std::numeric_limits<double>::infinity());
  std::vector<double> theta2(count, 0.0);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  const int own = SubmapOf(submaps, index);
  if (own >= 0) {
    const ChainUncertainty::Sigma c = chain.Between(submaps[own].first, index);
    xy2[own] = c.xy * c.xy;
    theta2[own] = c.theta * c.theta;
    queue.push({xy2[own], own});
  }
  while (!queue.empty()) {
    const auto [d, u] = queue.top();
    queue.pop();
    if (d > xy2[u]) continue;
    for (const Edge& e : edges[u]) {
      const double lever2 = (here - chain.Position(e.pivot)).squaredNorm();
      const double next = d + e.xy2 + e.theta2 * lever2;
      if (next < xy2[e.to]) {
        xy2[e.to] = next;
        theta2[e.to] = theta2[u] + e.theta2;
        queue.push({next, e.to});
      }
    }
  }
  for (int s = 0; s < count; ++s) {
    const int last = std::min(submaps[s].last, index);
    out[s] = chain.Between(last, index);
    if (std::isfinite(xy2[s]) && std::sqrt(xy2[s]) < out[s].xy) {
      out[s].xy = std::sqrt(xy2[s]);
      out[s].theta = std::sqrt(theta2[s]);
    }
  }
  return out;
}

}  // namespace waymark::laser_slam

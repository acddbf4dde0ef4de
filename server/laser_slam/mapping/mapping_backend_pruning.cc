#include "server/laser_slam/mapping/mapping_backend.h"

// Lifelong mapping (MappingOptions::prune_redundant_submaps, issue 38): submaps that add nothing
// the kept map does not already hold leave the graph, so that a robot driving loops through a
// mapped floor stops growing it.

#include <algorithm>
#include <cmath>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

// One 64-bit key per cell; cells are within +-2^31 of the origin (input_bounds.h keeps maps far
// smaller).
std::int64_t CellKey(std::int64_t x, std::int64_t y) {
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(x) << 32) ^
                                   (static_cast<std::uint64_t>(y) & 0xffffffffULL));
}

const std::shared_ptr<const PointCloud>& NoPoints() {
  static const auto* const kEmpty =
      new std::shared_ptr<const PointCloud>(std::make_shared<const PointCloud>());
  return *kEmpty;
}

}  // namespace

void MappingBackend::AppendCoverageCells(const Node& node, std::vector<Eigen::Vector2i>* cells) const {
  const double c = std::cos(node.global.theta), s = std::sin(node.global.theta);
  for (const Eigen::Vector2f& p : *node.points) {
    const double x = node.global.x + c * p.x() - s * p.y();
    const double y = node.global.y + s * p.x() + c * p.y();
    cells->emplace_back(static_cast<int>(std::floor(x / options_.prune_cell)),
                        static_cast<int>(std::floor(y / options_.prune_cell)));
  }
}

bool MappingBackend::TiedToKeptMapLocked(int s) const {
  const int first = submaps_[s].first, last = first + submaps_[s].count - 1;
  std::vector<int> ties;  // the nodes tied, each once
  for (const GraphConstraint& c : constraints_) {
    if (c.kind != GraphConstraint::Kind::kLoop || !c.enabled || c.to < first || c.to > last ||
        c.from >= first) {
      continue;
    }
    const auto older = std::upper_bound(submaps_.begin(), submaps_.begin() + s, c.from,
                                        [](int node, const Submap& m) { return node < m.first; });
    if (older != submaps_.begin() && !std::prev(older)->pruned) ties.push_back(c.to);
  }
  std::sort(ties.begin(), ties.end());
  return std::unique(ties.begin(), ties.end()) - ties.begin() >= options_.prune_min_ties;
}

void MappingBackend::DecidePruningLocked(int index) {
  // A cell is held when it or one of its 8 neighbours holds a kept submap's point.
  const auto held = [&](const Eigen::Vector2i& cell) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        if (coverage_.count(CellKey(cell.x() + dx, cell.y() + dy)) > 0) return true;
      }
    }
    return false;
  };
  for (int s = 0; s + options_.prune_after_submaps < static_cast<int>(submaps_.size()); ++s) {
    Submap& submap = submaps_[s];
    if (submap.decided) continue;
    const Submap& newer = submaps_[s + options_.prune_after_submaps];
    if (!newer.complete || newer.first + newer.count - 1 > index) return;
    submap.decided = true;
    std::vector<Eigen::Vector2i> cells;
    for (int j = submap.first; j < submap.first + submap.count; ++j) {
      AppendCoverageCells(nodes_[j], &cells);
    }
    // Tied to the kept map by a closure: without one, its overlap with the map may be the
    // graph's error, not the place. The first submap holds the map's frame and stays.
    if (s > 0 && TiedToKeptMapLocked(s)) {
      const auto fresh = std::count_if(cells.begin(), cells.end(),
                                       [&](const Eigen::Vector2i& cell) { return !held(cell); });
      if (static_cast<double>(fresh) <=
          options_.prune_max_new_fraction * static_cast<double>(cells.size())) {
        PruneSubmapLocked(s);
        continue;
      }
    }
    for (const Eigen::Vector2i& cell : cells) coverage_.insert(CellKey(cell.x(), cell.y()));
  }
}

void MappingBackend::MergeLoopLocked(const GraphConstraint& loop) {
  for (GraphConstraint& c : constraints_) {
    if (c.kind != GraphConstraint::Kind::kLoop || !c.enabled || c.from != loop.from ||
        c.to != loop.to) {
      continue;
    }
    // Two measurements of one relative pose: weighted by their information per axis, and never
    // trusted beyond one closure's sigma (their errors are not independent: the chain's share of
    // them is common), so that a thousand revisits do not make the map rigid.
    const Eigen::Vector3d wa = c.sigma.cwiseInverse().cwiseAbs2();
    const Eigen::Vector3d wb = loop.sigma.cwiseInverse().cwiseAbs2();
    const Eigen::Vector3d share = wb.cwiseQuotient(wa + wb);
    c.relative = Pose2{c.relative.x + share(0) * (loop.relative.x - c.relative.x),
                       c.relative.y + share(1) * (loop.relative.y - c.relative.y),
                       NormalizeAngle(c.relative.theta +
                                      share(2) * NormalizeAngle(loop.relative.theta - c.relative.theta))};
    c.sigma = (wa + wb)
                  .cwiseSqrt()
                  .cwiseInverse()
                  .cwiseMax(Eigen::Vector3d(options_.loop_sigma_xy, options_.loop_sigma_xy,
                                            options_.loop_sigma_theta));
    c.score = std::max(c.score, loop.score);
    return;
  }
  constraints_.push_back(loop);
}

Pose2 MappingBackend::PrunedPoseLocked(const Node& node) const {
  const Pose2 from_before = Compose(nodes_[node.anchor].global, node.from_anchor);
  const Pose2 from_after = Compose(nodes_[node.after].global, node.from_after);
  const double w = node.weight;
  return Pose2{(1 - w) * from_before.x + w * from_after.x, (1 - w) * from_before.y + w * from_after.y,
               NormalizeAngle(from_before.theta +
                              w * NormalizeAngle(from_after.theta - from_before.theta))};
}

void MappingBackend::PruneSubmapLocked(int s) {
  Submap& submap = submaps_[s];
  const int first = submap.first, last = submap.first + submap.count - 1;
  const int after = last + 1;  // exists: newer submaps are complete
  const int into = ChainConstraintLocked(first);
  if (into < 0 || after >= static_cast<int>(nodes_.size())) return;
  const int kept = constraints_[into].from;  // kept for good: older submaps are decided
  const double end_travel = nodes_[after].travel;
  // The chain from `kept` to `after` as one constraint: where the graph has them now (their loop
  // constraints' evidence included), to the chain's own uncertainty over the span.
  GraphConstraint span;
  span.kind = GraphConstraint::Kind::kChain;
  span.from = kept;
  span.to = after;
  span.relative = Relative(nodes_[kept].global, nodes_[after].global);
  const ChainUncertainty::Sigma sigma = chain_.Between(kept, after);
  span.sigma = Eigen::Vector3d(sigma.xy, sigma.xy, sigma.theta).cwiseMax(Eigen::Vector3d::Constant(1e-6));
  // The pruned nodes' loop constraints stay as constraints on the kept node nearest along the
  // chain (before or after the stretch): what the revisits measured about the kept map is not
  // lost, only trusted less by the chain's uncertainty between the two nodes.
  const auto nearest_kept = [&](int j) {
    return nodes_[j].travel - nodes_[kept].travel <= end_travel - nodes_[j].travel ? kept : after;
  };
  const auto widen = [&](const Eigen::Vector3d& own, int a, int b) {
    const ChainUncertainty::Sigma chain = chain_.Between(std::min(a, b), std::max(a, b));
    return Eigen::Vector3d(std::hypot(own(0), chain.xy), std::hypot(own(1), chain.xy),
                           std::hypot(own(2), chain.theta));
  };
  std::vector<GraphConstraint> moved;
  for (const GraphConstraint& c : constraints_) {
    if (c.kind != GraphConstraint::Kind::kLoop || !c.enabled || !options_.prune_keep_closures) continue;
    GraphConstraint m = c;
    if (c.to >= first && c.to <= last && c.from < first) {
      m.to = nearest_kept(c.to);
      m.relative = Compose(c.relative, Relative(nodes_[c.to].global, nodes_[m.to].global));
      m.sigma = widen(c.sigma, c.to, m.to);
    } else if (c.from >= first && c.from <= last && c.to > last) {
      m.from = nearest_kept(c.from);
      m.relative = Compose(Relative(nodes_[m.from].global, nodes_[c.from].global), c.relative);
      m.sigma = widen(c.sigma, c.from, m.from);
    } else {
      continue;
    }
    if (m.from != m.to) moved.push_back(m);
  }
  constraints_.erase(
      std::remove_if(constraints_.begin(), constraints_.end(),
                     [&](const GraphConstraint& c) {
                       if (c.kind == GraphConstraint::Kind::kChain) {
                         return c.to >= first && c.to <= after;
                       }
                       return (c.to >= first && c.to <= last) || (c.from >= first && c.from <= last);
                     }),
      constraints_.end());
  for (const GraphConstraint& m : moved) MergeLoopLocked(m);
  constraints_.push_back(span);
  // The stretch pruned before, back to `kept`, ended at `first`: it now ends at `after`.
  int stretch = first;
  while (stretch - 1 > kept && nodes_[stretch - 1].pruned) --stretch;
  const Node& end = nodes_[after];
  const double travel = std::max(end.travel - nodes_[kept].travel, 1e-9);
  for (int j = stretch; j <= last; ++j) {
    Node& n = nodes_[j];
    n.pruned = true;
    n.anchor = kept;
    n.after = after;
    n.from_anchor = Relative(nodes_[kept].global, n.global);
    n.from_after = Relative(end.global, n.global);
    n.weight = std::clamp((n.travel - nodes_[kept].travel) / travel, 0.0, 1.0);
    n.points = NoPoints();
  }
  // A global match on it waiting for confirmation goes too.
  pending_closures_.erase(std::remove_if(pending_closures_.begin(), pending_closures_.end(),
                                         [&](const PendingClosure& p) { return p.submap == s; }),
                          pending_closures_.end());
  submap.pruned = true;
  submap.frozen.clear();
  submap.frozen.shrink_to_fit();
  pyramid_cache_.Erase(s);
  seen_masks_.erase(s);
  ++stats_.submaps_pruned;
  stats_.nodes_pruned += submap.count;
}

}  // namespace waymark::laser_slam

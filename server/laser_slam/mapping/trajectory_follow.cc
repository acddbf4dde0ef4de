#include "server/laser_slam/mapping/trajectory_follow.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <queue>
#include <utility>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/laser_slam/mapping/origin_smoothing.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {

Pose2 OriginAt(const std::vector<OriginSample>& samples, double stamp) {
  if (samples.empty()) return Pose2{};
  if (stamp <= samples.front().stamp) return samples.front().origin;
  if (stamp >= samples.back().stamp) return samples.back().origin;
  const auto after = std::upper_bound(
      samples.begin(), samples.end(), stamp,
      [](double s, const OriginSample& sample) { return s < sample.stamp; });
  const OriginSample& b = *after;
  const OriginSample& a = *(after - 1);
  const double span = b.stamp - a.stamp;
  const double f = span > 0 ? (stamp - a.stamp) / span : 1.0;
  return Pose2{a.origin.x + f * (b.origin.x - a.origin.x),
               a.origin.y + f * (b.origin.y - a.origin.y),
               NormalizeAngle(a.origin.theta + f * NormalizeAngle(b.origin.theta - a.origin.theta))};
}

void RefreshOrigins(const std::vector<NodeView>& nodes, std::vector<OriginSample>* samples) {
  for (OriginSample& sample : *samples) {
    if (!sample.matched) continue;
    const auto it = std::lower_bound(
        nodes.begin(), nodes.end(), sample.scan,
        [](const NodeView& node, std::uint64_t scan) { return node.scan < scan; });
    if (it == nodes.end() || it->scan != sample.scan) continue;
    sample.origin = Compose(sample.map_pose, Invert(it->global));
  }
}

absl::Status ValidateFollowOptions(const FollowOptions& o) {
  for (const auto& [value, name] :
       {std::pair{o.point_cell, "follow.point_cell"}, {o.grid_resolution, "follow.grid_resolution"},
        {o.grid_sigma, "follow.grid_sigma"}, {o.window_sigmas, "follow.window_sigmas"},
        {o.sigma_xy_floor, "follow.sigma_xy_floor"},
        {o.sigma_theta_floor, "follow.sigma_theta_floor"},
        {o.max_window_xy, "follow.max_window_xy"}, {o.max_window_theta, "follow.max_window_theta"},
        {o.max_uncertainty_window_xy, "follow.max_uncertainty_window_xy"},
        {o.max_uncertainty_window_theta, "follow.max_uncertainty_window_theta"},
        {o.rival_exclusion, "follow.rival_exclusion"}, {o.map_growth, "follow.map_growth"}}) {
    if (absl::Status s = Positive(value, name); !s.ok()) return s;
  }
  if (o.every_nodes < 1 || o.every_nodes > 1000 || o.query_nodes < 1 || o.query_nodes > 50 ||
      o.min_query_points < 1 || o.max_samples < 2 || !(o.sigma_xy_per_metre >= 0) ||
      !(o.sigma_theta_per_metre >= 0) || !(o.every_metres >= 0) ||
      !(o.min_score > 0 && o.min_score < 1) || !(o.rival_ratio > 0 && o.rival_ratio <= 1) ||
      o.max_window_theta > M_PI || o.max_uncertainty_window_theta > M_PI) {
    return absl::InvalidArgumentError(
        "follow: every_nodes must be in [1, 1000], every_metres >= 0, query_nodes in [1, 50], "
        "max_samples at least 2, the sigmas per metre >= 0, min_score in (0, 1), rival_ratio in "
        "(0, 1], max_window_theta and max_uncertainty_window_theta at most pi");
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<TrajectoryFollow>> TrajectoryFollow::Create(
    const FollowOptions& options, const OriginSample& tie) {
  if (absl::Status s = ValidateFollowOptions(options); !s.ok()) return s;
  return std::unique_ptr<TrajectoryFollow>(new TrajectoryFollow(options, tie));
}

absl::StatusOr<std::unique_ptr<TrajectoryFollow>> TrajectoryFollow::Resume(
    const FollowOptions& options, std::vector<OriginSample> samples) {
  if (samples.empty()) return absl::InvalidArgumentError("no origin samples to resume from");
  absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow = Create(options, samples.front());
  if (!follow.ok()) return follow.status();
  (*follow)->samples_ = std::move(samples);
  return follow;
}

bool TrajectoryFollow::WantsMap(std::size_t map_nodes) const {
  if (grid_ == nullptr) return map_nodes > 0;
  return static_cast<double>(map_nodes) >
         (1.0 + options_.map_growth) * static_cast<double>(grid_nodes_);
}

absl::Status TrajectoryFollow::SetMap(const PointCloud& others, std::size_t map_nodes,
                                      std::vector<MapPathPoint> path) {
  if (others.empty()) return absl::FailedPreconditionError("no other trajectory has points yet");
  LikelihoodGrid fine = BuildLikelihoodGrid(ThinPoints(others, options_.point_cell),
                                            options_.grid_resolution, options_.grid_sigma,
                                            kMaxOccupancyCells);
  if (fine.empty()) {
    return absl::InvalidArgumentError("the other trajectories span too many cells to match in");
  }
  grid_ = std::make_unique<SearchPyramid>(std::move(fine), 6);
  grid_nodes_ = map_nodes;
  path_ = std::move(path);
  return absl::OkStatus();
}

FollowOptions WideFollowWindows(FollowOptions options) {
  options.window_for_map_drift = true;
  options.window_from_uncertainty = false;
  options.max_window_xy = 30.0;
  options.max_window_theta = 1.5;
  return options;
}

FollowOptions NarrowFollowWindows(FollowOptions options) {
  options.window_from_uncertainty = false;
  options.window_for_map_drift = false;
  return options;
}

SearchWindow FollowWindow(const FollowOptions& options, double travel) {
  const double s = options.window_sigmas;
  return SearchWindow{
      std::min(options.max_window_xy,
               s * (options.sigma_xy_floor + options.sigma_xy_per_metre * travel)),
      std::min(options.max_window_theta,
               s * (options.sigma_theta_floor + options.sigma_theta_per_metre * travel))};
}

namespace {

// The least cost of a way between the path's nodes nearest to `from` and to `to`, through their
// trajectory's chain (each step costing step_cost(from index, to index)) and its closures (free),
// and, `across` trajectories, the nodes their samples relate (free); with the sum of the steps'
// side costs along that way. nullopt where no way joins the two ends (without `across`: where no
// one trajectory holds both). A linear pass for the nearest nodes and Dijkstra: an attempt every
// few nodes.
struct WayCost {
  double cost = 0.0;
  double side = 0.0;
};
std::optional<WayCost> LeastWay(const std::vector<MapPathPoint>& path, const Pose2& from,
                                const Pose2& to, bool across,
                                const std::function<WayCost(int from, int to)>& step_cost) {
  const auto nearest = [&path](const Pose2& p) {
    const MapPathPoint* best = nullptr;
    double best_sq = 0.0;
    for (const MapPathPoint& q : path) {
      const double sq = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y);
      if (best == nullptr || sq < best_sq) {
        best = &q;
        best_sq = sq;
      }
    }
    return best;
  };
  const MapPathPoint* a = nearest(from);
  const MapPathPoint* b = nearest(to);
  if (a == nullptr || b == nullptr || (!across && a->trajectory != b->trajectory)) {
    return std::nullopt;
  }
  const int start = static_cast<int>(a - path.data());
  const int goal = static_cast<int>(b - path.data());
  // The whole path across trajectories; else the start's trajectory (contiguous in the path).
  int first = 0, last = static_cast<int>(path.size()) - 1;
  if (!across) {
    first = last = start;
    while (first > 0 && path[first - 1].trajectory == a->trajectory) --first;
    while (last + 1 < static_cast<int>(path.size()) && path[last + 1].trajectory == a->trajectory) {
      ++last;
    }
  }
  std::vector<WayCost> best(static_cast<size_t>(last - first + 1),
                            WayCost{std::numeric_limits<double>::infinity(), 0.0});
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  best[start - first] = WayCost{};
  queue.push({0.0, start});
  while (!queue.empty()) {
    // Plain copies, not a structured binding: C++17 lambdas cannot capture bindings (clang).
    const double d = queue.top().first;
    const int i = queue.top().second;
    queue.pop();
    if (i == goal) return best[i - first];
    if (d > best[i - first].cost) continue;
    const auto relax = [&](int j, WayCost w) {
      if (j < first || j > last || d + w.cost >= best[j - first].cost) return;
      best[j - first] = WayCost{d + w.cost, best[i - first].side + w.side};
      queue.push({d + w.cost, j});
    };
    // The chain's neighbours (the trajectories lie one after another in the path).
    for (const int j : {i - 1, i + 1}) {
      if (j >= first && j <= last && path[j].trajectory == path[i].trajectory) {
        relax(j, step_cost(i, j));
      }
    }
    for (int j : path[i].closes_to) relax(j, WayCost{});
    if (across) {
      for (int j : path[i].matched_to) relax(j, WayCost{});
    }
  }
  return std::nullopt;  // no way: two trajectories no match relates
}

}  // namespace

double MapTravelBetween(const std::vector<MapPathPoint>& path, const Pose2& from, const Pose2& to) {
  const std::optional<WayCost> way = LeastWay(path, from, to, false, [&path](int i, int j) {
    return WayCost{std::abs(path[j].along - path[i].along), 0.0};
  });
  return way ? way->cost : 0.0;
}

ChainUncertainty::Sigma MapUncertaintyBetween(const std::vector<MapPathPoint>& path,
                                              const Pose2& from, const Pose2& to) {
  // The swing of a step's heading error is taken about the node the way comes from, to the end.
  const std::optional<WayCost> way = LeastWay(path, from, to, true, [&path, &to](int i, int j) {
    const Eigen::Vector3d& sigma = path[std::max(i, j)].step_sigma;
    const double swing_sq =
        (to.x - path[i].x) * (to.x - path[i].x) + (to.y - path[i].y) * (to.y - path[i].y);
    const double xy = std::max(sigma(0), sigma(1));
    const double theta_sq = sigma(2) * sigma(2);
    return WayCost{xy * xy + theta_sq * swing_sq, theta_sq};
  });
  if (!way) return {};
  return ChainUncertainty::Sigma{std::sqrt(way->cost), std::sqrt(way->side)};
}

int TrajectoryFollow::Advance(const std::vector<NodeView>& nodes, int max_attempts) {
  if (nodes.empty() || grid_ == nullptr) return 0;
  RefreshOrigins(nodes, &samples_);  // the session's closures since moved its nodes
  const int n = static_cast<int>(nodes.size());
  if (last_attempt_ == -2) {
    // Counted from the first node after the last sample's (the tie's, unless resumed): that
    // sample observed the origin there.
    int first = 0;
    while (first < n && nodes[first].stamp <= samples_.back().stamp) ++first;
    if (first >= n) return 0;
    last_attempt_ = first - 1;
    next_try_ = first;
  }
  int looked = 0;
  // In node order, at most max_attempts now: a caller behind (a replay faster than the matching)
  // catches up over later calls, the same attempts in all.
  for (int node = NextAttempt(nodes); max_attempts > 0 && node >= 0; node = NextAttempt(nodes)) {
    next_try_ = node + 1;
    const PointCloud query = QueryAt(nodes, node);
    // Too few points to match (its session pruned the nodes of the query, which keep no points):
    // the next node is due, so that how often the robot is matched does not depend on what its
    // session had pruned when the follow got there.
    if (static_cast<int>(query.size()) < options_.min_query_points) continue;
    Attempt(nodes, node, query);
    last_attempt_ = node;
    --max_attempts;
    ++looked;
  }
  return looked;
}

int TrajectoryFollow::NextAttempt(const std::vector<NodeView>& nodes) const {
  double travel = 0.0;
  for (int node = last_attempt_ + 1; node < static_cast<int>(nodes.size()); ++node) {
    if (node > 0) {
      travel += std::hypot(nodes[node].global.x - nodes[node - 1].global.x,
                           nodes[node].global.y - nodes[node - 1].global.y);
    }
    if (node >= next_try_ && (node - last_attempt_ >= options_.every_nodes ||
                              (options_.every_metres > 0 && travel >= options_.every_metres))) {
      return node;
    }
  }
  return -1;
}

SearchWindow TrajectoryFollow::TravelWindow(const std::vector<NodeView>& nodes, int node,
                                            const Pose2& predicted) const {
  // How far the origin may have drifted since the last sample: the travel between.
  const OriginSample& last = samples_.back();
  double travel = 0.0;
  for (int i = node; i > 0 && nodes[i].stamp > last.stamp; --i) {
    travel += std::hypot(nodes[i].global.x - nodes[i - 1].global.x,
                         nodes[i].global.y - nodes[i - 1].global.y);
  }
  if (options_.window_for_map_drift && !path_.empty()) {
    const int last_node = NodeOfScan(nodes, last.scan);
    if (last_node >= 0) {
      travel += MapTravelBetween(
          path_, Compose(OriginAt(samples_, last.stamp), nodes[last_node].global), predicted);
    }
  }
  return FollowWindow(options_, travel);
}

SearchWindow TrajectoryFollow::UncertaintyWindow(const std::vector<NodeView>& nodes, int node,
                                                 const Pose2& predicted) const {
  // The robot's own chain since the last sample (its last node before it on), each step's heading
  // error swung to `node`.
  const OriginSample& last = samples_.back();
  int since = node;
  while (since > 0 && nodes[since].stamp > last.stamp) --since;
  ChainUncertainty chain;
  for (int i = since; i <= node; ++i) {
    chain.Append(Eigen::Vector2d(nodes[i].global.x, nodes[i].global.y),
                 i == since
                     ? Eigen::Vector3d::Zero()
                     : ChainStepSigma(nodes[i], Relative(nodes[i - 1].global, nodes[i].global)));
  }
  const ChainUncertainty::Sigma own = chain.Between(0, chain.size() - 1);
  ChainUncertainty::Sigma map;
  const int last_node = NodeOfScan(nodes, last.scan);
  if (!path_.empty() && last_node >= 0) {
    map = MapUncertaintyBetween(
        path_, Compose(OriginAt(samples_, last.stamp), nodes[last_node].global), predicted);
  }
  const double s = options_.window_sigmas;
  const SearchWindow travel = TravelWindow(nodes, node, predicted);
  return SearchWindow{
      std::max(travel.xy, std::min(options_.max_uncertainty_window_xy,
                                   s * std::sqrt(options_.sigma_xy_floor * options_.sigma_xy_floor +
                                                 own.xy * own.xy + map.xy * map.xy))),
      std::max(travel.theta,
               std::min(options_.max_uncertainty_window_theta,
                        s * std::sqrt(options_.sigma_theta_floor * options_.sigma_theta_floor +
                                      own.theta * own.theta + map.theta * map.theta)))};
}

PointCloud TrajectoryFollow::QueryAt(const std::vector<NodeView>& nodes, int node) const {
  PointCloud query;
  for (int i = std::max(0, node - options_.query_nodes + 1); i <= node; ++i) {
    if (nodes[i].points == nullptr) continue;
    AppendTransformed(*nodes[i].points, Relative(nodes[node].global, nodes[i].global), &query);
  }
  return ThinPoints(query, options_.point_cell);
}

bool TrajectoryFollow::Attempt(const std::vector<NodeView>& nodes, int node,
                               const PointCloud& query) {
  const NodeView& at = nodes[node];
  const Pose2 predicted = Compose(OriginAt(samples_, at.stamp), at.global);
  const SearchWindow window = options_.window_from_uncertainty
                                  ? UncertaintyWindow(nodes, node, predicted)
                                  : TravelWindow(nodes, node, predicted);
  ++progress_.attempts;
  const std::optional<GridMatch> match =
      MatchInWindow(*grid_, query, predicted, window, options_.min_score);
  if (match) progress_.reads += match->candidates * static_cast<std::int64_t>(query.size());
  if (!match || match->score < options_.min_score) {
    ++progress_.weak;
    return false;
  }
  // The window's box reaches window_sigmas in x and in y, its corners farther: a match there is
  // farther from the prediction than the uncertainty allows (a look-alike a few metres off, where
  // the robot drives what the map does not hold yet: `building`, seed 4, 3.2 m at the corner of a
  // 2.3 m window).
  if (options_.window_from_uncertainty &&
      std::hypot(match->pose.x - predicted.x, match->pose.y - predicted.y) > window.xy) {
    ++progress_.beyond;
    return false;
  }
  // A rival in the same window: the match could slide (a corridor) or be a look-alike nearby.
  const std::optional<GridMatch> rival =
      FindRival(*grid_, query, predicted, window, match->pose, options_.rival_exclusion,
                options_.rival_ratio * match->lattice_score);
  if (rival) {
    progress_.reads += rival->candidates * static_cast<std::int64_t>(query.size());
    ++progress_.ambiguous;
    return false;
  }
  ++progress_.matched;
  samples_.push_back(
      OriginSample{at.scan, at.stamp, Compose(match->pose, Invert(at.global)), true, match->pose});
  if (static_cast<int>(samples_.size()) > options_.max_samples) {
    // Bounded: every other sample dropped, the first (the tie) and the newest kept.
    std::vector<OriginSample> thinned;
    for (size_t i = 0; i < samples_.size(); ++i) {
      if (i % 2 == 0 || i + 1 == samples_.size()) thinned.push_back(samples_[i]);
    }
    samples_ = std::move(thinned);
  }
  return true;
}

}  // namespace waymark::laser_slam

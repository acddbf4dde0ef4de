#include "server/laser_slam/mapping/trajectory_tie.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/map_consistency.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/laser_slam/mapping/origin_smoothing.h"
#include "server/laser_slam/mapping/pose_cells.h"
#include "server/laser_slam/mapping/search_clock.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {

struct TrajectoryTie::Grids {
  SearchPyramid fine;    // refinement (depth 6, as the localizer's tracking grid)
  SearchPyramid coarse;  // the global search
};

namespace {

// The window both a match and its rival are refined in again before they are compared: wider
// than GlobalSearch's (0.05 rad), never reaching from a rival to its match (rival_xy, rival_theta
// are larger).
constexpr double kRivalRefineXy = 0.3;
constexpr double kRivalRefineTheta = 0.15;

}  // namespace

absl::Status ValidateTieOptions(const TieOptions& o) {
  for (const auto& [value, name] :
       {std::pair{o.point_cell, "tie.point_cell"}, {o.grid_resolution, "tie.grid_resolution"},
        {o.grid_sigma, "tie.grid_sigma"}, {o.global_query_cell, "tie.global_query_cell"},
        {o.rival_xy, "tie.rival_xy"}, {o.rival_theta, "tie.rival_theta"},
        {o.agreement_xy, "tie.agreement_xy"}, {o.agreement_theta, "tie.agreement_theta"},
        {o.min_separation, "tie.min_separation"}, {o.refine_window_xy, "tie.refine_window_xy"},
        {o.refine_window_theta, "tie.refine_window_theta"}, {o.map_growth, "tie.map_growth"}}) {
    if (absl::Status s = Positive(value, name); !s.ok()) return s;
  }
  if (o.reads_per_scan < 1000 || o.reads_per_scan > (std::int64_t{1} << 50) ||
      o.reads_per_second < 0 || o.reads_per_second > (std::int64_t{1} << 50)) {
    return absl::InvalidArgumentError(
        "tie: reads_per_scan must be in [1000, 2^50] and reads_per_second in [0, 2^50]");
  }
  if (o.query_nodes < 1 || o.query_nodes > 50 || o.refine_nodes < o.query_nodes ||
      o.refine_nodes > 200 || o.min_query_points < 1 || o.global_coarsening < 1 ||
      o.global_coarsening > 8 || o.global_depth < 0 || o.global_depth > 10 ||
      o.max_candidates < 1 || o.max_candidates > 100 || !(o.min_score > 0 && o.min_score < 1)) {
    return absl::InvalidArgumentError(
        "tie: query_nodes must be in [1, 50], refine_nodes in [query_nodes, 200], "
        "global_coarsening in [1, 8], global_depth in [0, 10], max_candidates in [1, 100], "
        "min_score in (0, 1)");
  }
  if (o.rival_xy < 2 * kRivalRefineXy || o.rival_theta < 2 * kRivalRefineTheta) {
    return absl::InvalidArgumentError(absl::StrCat(
        "tie: rival_xy must be at least ", 2 * kRivalRefineXy, " m and rival_theta at least ",
        2 * kRivalRefineTheta, " rad (a rival and its match are refined again ", kRivalRefineXy,
        " m and ", kRivalRefineTheta, " rad around each, which must not meet)"));
  }
  if (!(o.rival_floor > 0 && o.rival_floor <= o.rival_ratio && o.rival_ratio <= 1)) {
    return absl::InvalidArgumentError(
        "tie: 0 < rival_floor <= rival_ratio <= 1 (a rival is looked for down to rival_floor)");
  }
  return absl::OkStatus();
}

std::vector<OriginSample> CurrentOrigins(const TiedTrajectory& trajectory) {
  return SmoothOrigins(trajectory.nodes, trajectory.samples);
}

std::vector<GraphConstraint> LoopsInForce(const TiedTrajectory& trajectory) {
  const int n = static_cast<int>(trajectory.nodes.size());
  std::vector<GraphConstraint> loops;
  for (const GraphConstraint& loop : trajectory.loops) {
    if (loop.enabled && loop.from >= 0 && loop.to >= 0 && loop.from < n && loop.to < n) {
      loops.push_back(loop);
    }
  }
  return loops;
}

std::vector<NodeView> NodesInMapFrame(const TiedTrajectory& trajectory) {
  return NodesPlacedBy(trajectory, CurrentOrigins(trajectory));
}

std::vector<NodeView> NodesPlacedBy(const TiedTrajectory& trajectory,
                                    const std::vector<OriginSample>& origins) {
  std::vector<NodeView> nodes = trajectory.nodes;
  const bool per_node = origins.size() == nodes.size();
  for (size_t i = 0; i < nodes.size(); ++i) {
    nodes[i].global =
        per_node && origins[i].matched && origins[i].scan == nodes[i].scan
            ? origins[i].map_pose
            : Compose(origins.empty() ? trajectory.origin : OriginAt(origins, nodes[i].stamp),
                      nodes[i].global);
  }
  return nodes;
}

std::vector<MapPathPoint> MapPath(const std::vector<TiedTrajectory>& trajectories) {
  std::vector<MapPathPoint> path;
  for (size_t t = 0; t < trajectories.size(); ++t) {
    double along = 0.0;
    const int first = static_cast<int>(path.size());
    const std::vector<NodeView> nodes = NodesInMapFrame(trajectories[t]);
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (i > 0) {
        along += std::hypot(nodes[i].global.x - nodes[i - 1].global.x,
                            nodes[i].global.y - nodes[i - 1].global.y);
      }
      MapPathPoint point{nodes[i].global.x, nodes[i].global.y, static_cast<int>(t), along, {}};
      if (i > 0)
        point.step_sigma = ChainStepSigma(nodes[i], Relative(nodes[i - 1].global, nodes[i].global));
      path.push_back(std::move(point));
    }
    for (const GraphConstraint& loop : LoopsInForce(trajectories[t])) {
      path[first + loop.from].closes_to.push_back(first + loop.to);
      path[first + loop.to].closes_to.push_back(first + loop.from);
    }
  }
  // Each follow sample (and the tie) relates its node to the other trajectories' node nearest to
  // where it placed it, looked for within kLinkReach (a match's place is next to the map it
  // matched).
  constexpr double kLinkReach = 2.0;
  std::vector<Pose2> at;
  std::vector<int> owner;
  at.reserve(path.size());
  owner.reserve(path.size());
  for (const MapPathPoint& point : path) {
    at.push_back(Pose2{point.x, point.y, 0.0});
    owner.push_back(point.trajectory);
  }
  const PoseCells cells(at, owner, kLinkReach);
  int first = 0;
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const TiedTrajectory& trajectory = trajectories[t];
    for (const OriginSample& sample : trajectory.samples) {
      const int node = NodeOfScan(trajectory.nodes, sample.scan);
      if (node < 0) continue;
      const int nearest = cells.NearestOther(static_cast<int>(t), at[first + node]);
      if (nearest < 0) continue;
      path[first + node].matched_to.push_back(nearest);
      path[nearest].matched_to.push_back(first + node);
    }
    first += static_cast<int>(trajectory.nodes.size());
  }
  return path;
}

PointCloud MapCloud(const std::vector<TiedTrajectory>& trajectories, double cell) {
  PointCloud map;
  for (const TiedTrajectory& trajectory : trajectories) {
    for (const NodeView& node : NodesInMapFrame(trajectory)) {
      if (node.points != nullptr) AppendTransformed(*node.points, node.global, &map);
    }
  }
  return ThinPoints(map, cell);
}

namespace {

// The trajectory's nodes in the map frame, in whole submaps of the self-check's size (a trailing
// part is left out, so that no submap of the check mixes two trajectories).
void AppendWholeSubmaps(const TiedTrajectory& trajectory, int submap_nodes,
                        std::vector<NodeView>* out) {
  std::vector<NodeView> nodes = NodesInMapFrame(trajectory);
  nodes.resize(nodes.size() - nodes.size() % static_cast<size_t>(submap_nodes));
  out->insert(out->end(), std::make_move_iterator(nodes.begin()),
              std::make_move_iterator(nodes.end()));
}

}  // namespace

bool TieKeepsTheMapConsistent(const std::vector<TiedTrajectory>& map,
                              const std::vector<NodeView>& joining, const Pose2& tie,
                              std::string* why) {
  const MapConsistencyOptions options;
  std::vector<NodeView> map_nodes, joining_nodes;
  for (const TiedTrajectory& trajectory : map) {
    AppendWholeSubmaps(trajectory, options.submap_nodes, &map_nodes);
  }
  AppendWholeSubmaps(TiedTrajectory{tie, joining, {}, {}}, options.submap_nodes, &joining_nodes);
  std::vector<NodeView> together = map_nodes;
  together.insert(together.end(), joining_nodes.begin(), joining_nodes.end());
  const absl::StatusOr<MapConsistencyReport> alone_map = CheckMapConsistency(map_nodes, options);
  const absl::StatusOr<MapConsistencyReport> alone_joining =
      CheckMapConsistency(joining_nodes, options);
  const absl::StatusOr<MapConsistencyReport> both = CheckMapConsistency(together, options);
  if (!alone_map.ok() || !alone_joining.ok() || !both.ok()) return true;  // nothing to say
  const int before = alone_map->tiles_contradicting + alone_joining->tiles_contradicting;
  if (why != nullptr) {
    *why = absl::StrCat(both->tiles_contradicting, " areas of 5 m contradict themselves with the "
                        "robot placed there, against ", before, " in the map and the robot alone (",
                        both->verdict, ")");
  }
  // Only a map and a robot that agree with themselves can show that the robot placed there
  // contradicts the map: where either already contradicts itself (noisy odometry, a wrong
  // closure), a right tie adds areas too (fhw-corrected-medium: 10 before, 15 with its right
  // tie), and the check cannot tell.
  if (before > 0) return true;
  return both->tiles_contradicting == 0;
}

absl::StatusOr<std::unique_ptr<TrajectoryTie>> TrajectoryTie::Create(const TieOptions& options) {
  if (absl::Status s = ValidateTieOptions(options); !s.ok()) return s;
  return std::unique_ptr<TrajectoryTie>(new TrajectoryTie(options));
}

void TrajectoryTie::Refuse() {
  if (!progress_.tie) return;
  progress_.tie.reset();
  progress_.tie_scan = 0;
  progress_.tied_at_scan = 0;
  ++progress_.refused;
  candidates_.clear();
  progress_.state = TieState::kSearching;
}

bool TrajectoryTie::WantsMap(std::size_t map_nodes) const {
  if (grids_ == nullptr) return map_nodes > 0;
  return static_cast<double>(map_nodes) >
         (1.0 + options_.map_growth) * static_cast<double>(grid_nodes_);
}

absl::Status TrajectoryTie::SetMap(const PointCloud& map_points, std::size_t map_nodes) {
  if (map_points.empty()) return absl::FailedPreconditionError("the map has no points yet");
  const double k = options_.global_coarsening;
  // A whole map, not a submap: as large as an occupancy grid may be (as the localizer's).
  LikelihoodGrid fine = BuildLikelihoodGrid(ThinPoints(map_points, options_.point_cell),
                                            options_.grid_resolution, options_.grid_sigma,
                                            kMaxOccupancyCells);
  if (fine.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("the map spans more than ", kMaxOccupancyCells,
                                                   " cells at ", options_.grid_resolution, " m"));
  }
  LikelihoodGrid coarse = BuildLikelihoodGrid(ThinPoints(map_points, k * options_.point_cell),
                                              k * options_.grid_resolution,
                                              k * options_.grid_sigma, kMaxOccupancyCells);
  grids_ = std::make_shared<const Grids>(
      Grids{SearchPyramid(std::move(fine), 6), SearchPyramid(std::move(coarse),
                                                             options_.global_depth)});
  grid_nodes_ = map_nodes;
  return absl::OkStatus();
}

PointCloud TrajectoryTie::Query(const std::vector<NodeView>& joining, int first, int last,
                                double cell) const {
  PointCloud query;
  const Pose2& frame = joining[last].global;
  for (int i = std::max(0, first); i <= last; ++i) {
    if (joining[i].points == nullptr) continue;
    AppendTransformed(*joining[i].points, Relative(frame, joining[i].global), &query);
  }
  return ThinPoints(query, cell);
}

bool TrajectoryTie::StartSearch(const std::vector<NodeView>& joining, int node) {
  search_node_ = node;
  PointCloud query = Query(joining, node - options_.query_nodes + 1, node, options_.point_cell);
  if (static_cast<int>(query.size()) < options_.min_query_points) return false;
  GlobalSearchSettings settings;
  settings.min_score = options_.min_score;
  settings.rival_xy = options_.rival_xy;
  settings.rival_theta = options_.rival_theta;
  settings.rival_floor = options_.rival_floor;
  settings.query_cell = options_.global_query_cell;
  search_grids_ = grids_;
  search_ = std::make_unique<GlobalSearch>(search_grids_->coarse, search_grids_->fine, settings,
                                           joining[node].scan, joining[node].stamp,
                                           joining[node].global, query);
  progress_.state = TieState::kSearching;
  return true;
}

const TieProgress& TrajectoryTie::Advance(const std::vector<NodeView>& joining,
                                          std::int64_t max_reads) {
  if (joining.empty()) return progress_;
  const double newest_scan = static_cast<double>(joining.back().scan);
  if (progress_.clock_scan < static_cast<double>(joining.front().scan)) {
    progress_.clock_scan = static_cast<double>(joining.front().scan);
  }
  const SearchClockRates rates{static_cast<double>(options_.reads_per_scan),
                               static_cast<double>(options_.reads_per_second)};
  while (!progress_.tie && max_reads > 0) {
    if (search_ == nullptr) {
      if (grids_ == nullptr) {
        progress_.clock_scan = newest_scan;  // nothing to search in yet
        break;
      }
      // The newest node the clock has reached, if not searched yet and with enough before it.
      int node = static_cast<int>(joining.size()) - 1;
      while (node >= 0 && static_cast<double>(joining[node].scan) > progress_.clock_scan) --node;
      const int first_searchable = std::max(search_node_ + 1, options_.query_nodes - 1);
      if (node < first_searchable) {
        // Nothing new at the clock's scan: it moves on to the next searchable node (the robot
        // had nothing to search in between), or to the newest scan.
        if (first_searchable >= static_cast<int>(joining.size())) {
          progress_.clock_scan = newest_scan;
          break;
        }
        progress_.clock_scan = static_cast<double>(joining[first_searchable].scan);
        continue;
      }
      if (!StartSearch(joining, node)) continue;  // too few points: the next node then
    }
    // What the scans up to the newest have granted and the clock has not spent yet.
    const double granted = ReadsGranted(joining, rates, progress_.clock_scan, newest_scan);
    if (granted < 1.0) break;
    const std::int64_t budget =
        std::min<std::int64_t>(max_reads, static_cast<std::int64_t>(granted));
    const std::int64_t before = search_->outcome().reads;
    const bool over = search_->Resume(budget);
    const std::int64_t spent = std::max<std::int64_t>(search_->outcome().reads - before, 1);
    progress_.reads += spent;
    progress_.clock_scan = std::min(
        newest_scan, ClockAfter(joining, rates, progress_.clock_scan, static_cast<double>(spent)));
    max_reads -= spent;
    if (!over) continue;
    TakeAnswer(joining);
    search_.reset();
    search_grids_.reset();
  }
  if (progress_.tie && progress_.tied_at_scan == 0) {
    progress_.tied_at_scan = static_cast<std::uint64_t>(std::ceil(progress_.clock_scan));
  }
  return progress_;
}

int TieWinner(const std::vector<TieVote>& votes, bool outvote) {
  int winner = -1;
  int support = 1;  // the fresh match itself
  int against = 0;
  for (size_t i = 0; i < votes.size(); ++i) {
    if (!votes[i].independent) continue;
    if (!votes[i].agrees) {
      ++against;
      continue;
    }
    ++support;
    if (winner < 0) winner = static_cast<int>(i);
    if (!outvote) return winner;
  }
  return support > against ? winner : -1;
}

bool TrajectoryTie::Agree(const std::vector<NodeView>& joining, const Candidate& a,
                          const Candidate& b) const {
  // The motion between the two nodes as the joining trajectory's graph now has it.
  const Pose2 motion = Relative(joining[a.node].global, joining[b.node].global);
  const auto close = [this](const Pose2& d) {
    return std::hypot(d.x, d.y) <= options_.agreement_xy &&
           std::abs(NormalizeAngle(d.theta)) <= options_.agreement_theta;
  };
  // Both ways: a heading error of the first match swings the second node about the first.
  return close(Relative(Compose(a.match, motion), b.match)) &&
         close(Relative(Compose(b.match, Invert(motion)), a.match));
}

Pose2 TrajectoryTie::Refine(const std::vector<NodeView>& joining, const Candidate& a,
                            const Candidate& b) const {
  const Pose2 agreed = Compose(b.match, Invert(joining[b.node].global));
  const int first = std::max(a.node - options_.query_nodes + 1,
                             b.node - options_.refine_nodes + 1);
  const PointCloud query = Query(joining, first, b.node, options_.point_cell);
  const std::optional<GridMatch> refined =
      MatchInWindow(grids_->fine, query, b.match,
                    SearchWindow{options_.refine_window_xy, options_.refine_window_theta}, 0.0);
  // A stretch reaching beyond the mapped part scores lower (its points off the map count as
  // misses); the refinement is kept only when it still scores as a match.
  if (!refined || refined->score < options_.min_score) return agreed;
  return Compose(refined->pose, Invert(joining[b.node].global));
}

void TrajectoryTie::TakeAnswer(const std::vector<NodeView>& joining) {
  const GlobalSearchOutcome& outcome = search_->outcome();
  ++progress_.searches;
  progress_.last_score = outcome.match ? outcome.match->score : 0.0;
  progress_.last_rival_ratio = 0.0;
  if (!outcome.match) {
    if (candidates_.empty()) progress_.state = TieState::kSearching;
    return;
  }
  if (outcome.rival && outcome.match->score > 0) {
    // GlobalSearch refines each from its coarse lattice pose in a window of 0.05 rad, narrower
    // than the coarse search's angular step: the twin of a match in two identical rooms came out
    // anywhere from 0.80 to 1.00 of it. Both are refined again here in one wider window, so that
    // the two peaks are compared alike (a tie is never undone; the localizer's fix is).
    const PointCloud query = Query(joining, search_node_ - options_.query_nodes + 1, search_node_,
                                   options_.point_cell);
    const SearchWindow window{kRivalRefineXy, kRivalRefineTheta};
    double match_score = outcome.match->score, rival_score = outcome.rival->score;
    for (auto [pose, score] : {std::pair{outcome.match->pose, &match_score},
                               std::pair{outcome.rival->pose, &rival_score}}) {
      const std::optional<GridMatch> again =
          MatchInWindow(search_grids_->fine, query, pose, window, 0.0);
      if (!again) continue;
      progress_.reads += again->candidates * static_cast<std::int64_t>(query.size());
      *score = std::max(*score, again->score);
    }
    progress_.last_rival_ratio = std::min(1.0, rival_score / match_score);
  }
  if (progress_.last_rival_ratio >= options_.rival_ratio) {
    // Either place could be the robot's: this match is no evidence for any transform, and the
    // unique matches before it are dropped too, as the localizer drops the one waiting for
    // agreement. Where the map holds a look-alike of the robot's place, a "unique" match nearby
    // may be the look-alike winning by the grid's phase: in two identical rooms the wrong twin
    // scored 0.98 against the right one's 0.87 (walls on cell boundaries), three such matches
    // agreed, and the robot was tied into the wrong room.
    candidates_.clear();
    ++progress_.ambiguous;
    progress_.state = TieState::kAmbiguous;
    return;
  }
  ++progress_.matches;
  const Candidate fresh{search_node_, outcome.match->pose, outcome.match->score};
  // Travel along the joining trajectory, node by node (its graph poses now).
  std::vector<double> travel(joining.size(), 0.0);
  for (size_t i = 1; i < joining.size(); ++i) {
    travel[i] = travel[i - 1] + std::hypot(joining[i].global.x - joining[i - 1].global.x,
                                           joining[i].global.y - joining[i - 1].global.y);
  }
  // Each kept candidate's vote on the fresh one's transform, newest first (the newest agreeing
  // one has the least drift of the joining trajectory between the two).
  std::vector<TieVote> votes;
  bool any_agrees = false;
  for (auto it = candidates_.rbegin(); it != candidates_.rend(); ++it) {
    const Candidate& older = *it;
    TieVote vote;
    // Independent: no scan in both queries, and the robot moved on between them.
    vote.independent = fresh.node - older.node >= options_.query_nodes &&
                       travel[fresh.node] - travel[older.node] >= options_.min_separation;
    // Without the vote the first agreeing one ties: the ones before it are not asked.
    if (vote.independent && (options_.outvote_disagreements || !any_agrees)) {
      vote.agrees = Agree(joining, older, fresh);
      any_agrees = any_agrees || vote.agrees;
      if (!vote.agrees) ++progress_.disagreements;
    }
    votes.push_back(vote);
  }
  const int winner = TieWinner(votes, options_.outvote_disagreements);
  if (winner >= 0) {
    const Candidate& agreeing = candidates_[candidates_.size() - 1 - static_cast<size_t>(winner)];
    progress_.tie = Refine(joining, agreeing, fresh);
    progress_.tie_scan = joining[fresh.node].scan;
    progress_.state = TieState::kTied;
    return;
  }
  if (any_agrees) ++progress_.outvoted;
  candidates_.push_back(fresh);
  if (static_cast<int>(candidates_.size()) > options_.max_candidates) {
    candidates_.erase(candidates_.begin());
  }
  progress_.state = TieState::kCandidate;
}

}  // namespace waymark::laser_slam

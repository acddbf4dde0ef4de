#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_FOLLOW_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_FOLLOW_H_

// A tied-in robot kept on the shared map (issue 38; docs/laser-slam.md, "Maps shared by
// robots"). TrajectoryTie finds where a joining robot's frame lies in the map once; after it, the
// robot's own drift carries it away from the other robots' map (ACES split for two robots: up to
// 3.8 m). Here its recent nodes are matched again, every `every_nodes` nodes or `every_metres`
// of travel, against the OTHER tied-in trajectories' points, in a local window around where its
// current origin puts them: no global search. The window is three sigmas of how far the origin may
// have drifted since the last match: a floor plus a share of the travel since, capped, or, where
// the chains' own uncertainty reaches farther (the robot's since its last match, the map's between
// there and here), that, with a match beyond three sigmas of it refused. A match counts when it
// scores at least min_score and no rival pose farther than rival_exclusion in the same window
// scores rival_ratio of it (a corridor sliding along itself, a look-alike room nearby).
//
// Each match observes the origin at its node: the match pose in the map frame composed with the
// inverse of the node's own pose. The origin is then not one transform but piecewise
// (PiecewiseOrigin): one sample per matched node, interpolated between samples by the nodes'
// stamps (the nodes are in stamp order), held before the first and after the last. Map-frame
// poses and the merged grid use the origin at each pose's stamp.
//
// Not a constraint in a pose graph: each sample is one match, kept as observed (the node's
// map-frame pose); its origin is derived again from the node's current pose (RefreshOrigins), so
// the robot's own loop closures after a match move the origin with them. Plain C++, no threads
// (map_tie_worker.h runs it).

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/chain_uncertainty.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// The origin observed at one node: map = origin (+) node pose.
struct OriginSample {
  std::uint64_t scan = 0;
  double stamp = 0.0;
  Pose2 origin;
  // What a follow-up match observed: the node's pose in the map frame (not for the tie's
  // sample). The robot's own loop closures move its nodes after they were matched, so the
  // origin is derived again from the node's current pose (RefreshOrigins): the match is the
  // observation, the origin at the time of the match is not.
  bool matched = false;
  Pose2 map_pose;
};

// For each matched sample whose node (by scan) is among `nodes` (oldest first, by scan): origin
// = map_pose (-) the node's current pose. Other samples keep their origin.
void RefreshOrigins(const std::vector<NodeView>& nodes, std::vector<OriginSample>* samples);

// Samples in stamp order; At() interpolates in x, y and heading (the shorter way), holding the
// first before it and the last after it. Empty: the identity.
Pose2 OriginAt(const std::vector<OriginSample>& samples, double stamp);

// A node of the other trajectories, where the map has it, and how far along its own trajectory it
// lies (metres from that trajectory's first node): what the window adds for the map's own drift.
struct MapPathPoint {
  double x = 0.0;
  double y = 0.0;
  int trajectory = 0;
  double along = 0.0;
  // The points (indices into the path) this node's own session closed a loop with: the map's
  // path between two places takes such a closure as a shortcut.
  std::vector<int> closes_to;
  // The points of other trajectories this node's follow samples matched it against (the nearest
  // to where the sample placed it): MapUncertaintyBetween goes across trajectories through them.
  std::vector<int> matched_to;
  // 1 sigma (x, y, theta) of the chain step from the trajectory's point before (ChainStepSigma;
  // zero for its first): what MapUncertaintyBetween adds up.
  Eigen::Vector3d step_sigma = Eigen::Vector3d::Zero();
};

struct FollowOptions {
  int every_nodes = 5;   // one match attempt every this many nodes (its newest)
  // ... or sooner, once the robot has travelled this far (m) since the last attempt: what
  // every_nodes nodes span where the session keeps a node per 0.25 m (MappingOptions::
  // node_travel), as in a raw log at 5 Hz or faster. A log that keeps one scan per metre or two
  // (the corrected logs of ../shared) makes each scan a node, and five of them span 4-5 m: the
  // robot was then looked at a third as often per metre. 0: nodes only.
  double every_metres = 1.25;
  int query_nodes = 5;   // the query: the points of this many nodes in the newest one's frame
  int min_query_points = 30;
  double point_cell = 0.05;
  double grid_resolution = 0.05;
  double grid_sigma = 0.05;
  // The window: window_sigmas times (floor + per metre of travel since the last sample), capped.
  double window_sigmas = 3.0;
  double sigma_xy_floor = 0.1;         // m: the window's floor is 0.3 m
  double sigma_theta_floor = 0.03;     // rad
  double sigma_xy_per_metre = 0.02;    // the robot's own drift, per metre travelled
  double sigma_theta_per_metre = 0.005;
  // The window may also grow with the map's own drift between the place of the last sample and
  // the place searched (the map's path between them, at sigma_*_per_metre, where one trajectory
  // of the map holds both): a robot that drives a loop another robot left open comes back to
  // that robot's start as far from where its map has it as the other robot drifted round the
  // loop (ACES at 10 %: 4.5 m, where its own travel since the last sample gave a 2.7 m window).
  // Off, and the caps at 2 m and 0.4 rad: with this on and caps of 30 m and 1.5 rad, the map's
  // graph closed ACES's open loops (split for two robots at 10 %: 0.093 -> 0.043 m), but in the
  // `building` world a robot exploring a room the map did not hold yet matched its mapped twin
  // and was placed 10 m off (docs/results.md, "One pose graph for the whole map"). The rival
  // test cannot see a look-alike whose twin the map does not hold.
  bool window_for_map_drift = false;
  // Beyond those windows, as far as the uncertainty the estimates carry reaches (the default;
  // NarrowFollowWindows turns it off): window_sigmas times the root of the floor squared, the robot's
  // own chain uncertainty since its last sample (its nodes' step sigmas, with the swing of each
  // heading error over the distance to the node searched, as the loop search's ChainUncertainty)
  // and the map's between the last sample's place and the place searched
  // (MapUncertaintyBetween), capped at max_uncertainty_window_*. A map that closed its loops is
  // searched no farther than the travel windows reach; one that another robot drove round an open
  // loop, as far as that robot's steps allow. The travel windows stay the least, so the follow
  // never searches less than it did before (the uncertainty alone is smaller where the steps
  // matched well; that the floor matters was not shown, docs/results.md).
  bool window_from_uncertainty = true;
  double max_uncertainty_window_xy = 30.0;
  double max_uncertainty_window_theta = 1.5;
  double max_window_xy = 2.0;
  double max_window_theta = 0.4;
  double min_score = 0.6;
  double rival_exclusion = 0.3;  // m (root mean square over the points)
  double rival_ratio = 0.9;
  // The grid of the other trajectories is drawn again once they hold this fraction more nodes.
  double map_growth = 0.1;
  // Samples kept (the oldest are thinned out beyond this: every other one dropped).
  int max_samples = 20000;
};

absl::Status ValidateFollowOptions(const FollowOptions& options);

// `options` with the wide windows: the map's drift in the window (window_for_map_drift) and caps
// of 30 m and 1.5 rad. Measured against the default (docs/results.md, "Tried, not kept: wide
// follow windows with a check on the jump"): raw ACES and MIT Killian split among robots reach
// the single session's error (0.042-0.050 m, against 0.084-0.141 m), but in a floor of
// look-alike rooms a robot may be placed in the wrong one (the `building` world: 1.7-4.2 m mean
// error in 4 of 5 seeds, 0.11-0.77 m with the default). The server's --slam-map-follow-windows
// wide, for buildings without look-alike rooms; not the default.
FollowOptions WideFollowWindows(FollowOptions options = {});

// `options` with the travel's windows only (window_from_uncertainty off, no map drift): at most
// max_window_xy and max_window_theta, the default before the uncertainty's windows. The server's
// --slam-map-follow-windows narrow.
FollowOptions NarrowFollowWindows(FollowOptions options = {});

// The window of an attempt after `travel` metres (the robot's own since its last sample, plus the
// map's path between there and here): window_sigmas times the floor plus the drift per metre,
// capped.
SearchWindow FollowWindow(const FollowOptions& options, double travel);

// How far along one trajectory of the map two places lie apart: the shortest way between its
// nodes nearest to each along the trajectory and through its own loop closures (0 when their
// nearest nodes belong to different trajectories, or there are none). A robot's last sample and
// its next attempt near the two ends of a loop another robot left open are that robot's whole
// loop apart, however close they are in the map; where that robot closed the loop, they are not.
double MapTravelBetween(const std::vector<MapPathPoint>& path, const Pose2& from, const Pose2& to);

// How uncertain the map is about where `to` lies from `from` (their nearest nodes), along the
// trajectories' chains, their closures and, between two trajectories, the nodes their follow
// samples relate (matched_to; a closure or a sample adds nothing): each chain step on the way
// adds its xy variance and its heading variance times the squared distance from the step to the
// end (the swing), the least over the ways (Dijkstra on that variance). Zero where no way joins
// them (two trajectories no sample relates) or there is no path.
ChainUncertainty::Sigma MapUncertaintyBetween(const std::vector<MapPathPoint>& path,
                                              const Pose2& from, const Pose2& to);

struct FollowProgress {
  int attempts = 0;   // windowed matches tried
  int matched = 0;    // ... giving a sample
  int weak = 0;       // ... scoring below min_score (the robot off the others' map)
  int ambiguous = 0;  // ... refused for a rival pose
  // ... refused as farther from where the last sample puts the robot than window_sigmas of the
  // uncertainty (window_from_uncertainty: the window is a box for the search, the gate a circle)
  int beyond = 0;
  std::int64_t reads = 0;  // cell reads (candidates times points)
};

class TrajectoryFollow {
 public:
  // `tie`: the origin the robot was tied in at, observed at node `tie_stamp`/`tie_scan`.
  static absl::StatusOr<std::unique_ptr<TrajectoryFollow>> Create(const FollowOptions& options,
                                                                  const OriginSample& tie);
  // Goes on from the samples an earlier follow made (stored with the map: after a restart, or on
  // the server that took the map over), matching from the node after the last one on.
  // INVALID_ARGUMENT when `samples` is empty.
  static absl::StatusOr<std::unique_ptr<TrajectoryFollow>> Resume(
      const FollowOptions& options, std::vector<OriginSample> samples);
  TrajectoryFollow(const TrajectoryFollow&) = delete;
  TrajectoryFollow& operator=(const TrajectoryFollow&) = delete;

  bool WantsMap(std::size_t map_nodes) const;
  // The other tied-in trajectories' points in the map frame (MapCloud without this robot's), and
  // their nodes along their paths (MapPath; empty: the window knows nothing of the map's drift).
  absl::Status SetMap(const PointCloud& others, std::size_t map_nodes,
                      std::vector<MapPathPoint> path = {});

  // Matches the robot's nodes (its session's graph poses, oldest first, node i staying node i)
  // not looked at yet: at most `max_attempts` windowed matches now. Returns how many nodes it
  // looked at (max_attempts: there may be more to do now).
  int Advance(const std::vector<NodeView>& nodes, int max_attempts);

  const std::vector<OriginSample>& samples() const { return samples_; }
  const FollowProgress& progress() const { return progress_; }

 private:
  TrajectoryFollow(const FollowOptions& options, const OriginSample& tie)
      : options_(options), samples_{tie} {}
  // The window of an attempt at node `node`, whose pose the last sample's origin puts at
  // `predicted`: from the travel since (FollowWindow), or from the uncertainty of the robot's own
  // chain and of the map's (window_from_uncertainty).
  SearchWindow TravelWindow(const std::vector<NodeView>& nodes, int node,
                            const Pose2& predicted) const;
  SearchWindow UncertaintyWindow(const std::vector<NodeView>& nodes, int node,
                                 const Pose2& predicted) const;
  // The next node to try after last_attempt_: every_nodes on, or the first every_metres of
  // travel on, whichever comes first, and not before next_try_; -1: none of `nodes` yet.
  int NextAttempt(const std::vector<NodeView>& nodes) const;
  // The query of an attempt at node `node`: the newest query_nodes nodes' points in its frame,
  // thinned to point_cell.
  PointCloud QueryAt(const std::vector<NodeView>& nodes, int node) const;
  // One attempt at node `node` with its query (at least min_query_points); true when it gave a
  // sample.
  bool Attempt(const std::vector<NodeView>& nodes, int node, const PointCloud& query);

  const FollowOptions options_;
  std::unique_ptr<SearchPyramid> grid_;
  std::vector<MapPathPoint> path_;
  std::size_t grid_nodes_ = 0;
  std::vector<OriginSample> samples_;
  // The node after which the next attempt is counted (every_nodes, every_metres); -2: not yet
  // known (the node before the first after the tie's stamp, or the last sample's when resumed).
  int last_attempt_ = -2;
  int next_try_ = 0;  // the nodes before it were tried (with too few points, or matched)
  FollowProgress progress_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_FOLLOW_H_

// A tied-in robot kept on the shared map after its tie (issue 38, trajectory_follow.h): the
// second robot's own odometry drifts (a heading bias and a scale error, as a real robot's), so
// one fixed origin carries its map-frame poses away from the truth; matched again in local
// windows against the first robot's map, its piecewise origin keeps them within a few cm.

#include "server/laser_slam/mapping/trajectory_follow.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/trajectory_tie.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::Wall;

using testing::PillarOffice;
using testing::PolylinePath;

// The nodes a robot driving `truth` keeps in its own frame, its motion between nodes distorted by
// `scale` (along) and `heading_bias` (rad per node): drift. Its scans are the true ones.
std::vector<NodeView> DriftingNodes(const std::vector<Wall>& walls, const std::vector<Pose2>& truth,
                                    double scale, double heading_bias) {
  std::vector<NodeView> nodes;
  Pose2 own{};
  for (size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const Pose2 step = Relative(truth[i - 1], truth[i]);
      own = Compose(own, Pose2{step.x * scale, step.y * scale, step.theta + heading_bias});
    }
    NodeView node;
    node.scan = 3 * i + 1;
    node.stamp = static_cast<double>(i);
    node.global = own;
    node.points = std::make_shared<const PointCloud>(testing::ScanPoints(walls, truth[i]));
    nodes.push_back(node);
  }
  return nodes;
}

struct Errors {
  double max = 0.0;   // m, over the nodes after the tie
  double last = 0.0;  // m, at the last node
};

// Map-frame poses (origin at each node's stamp (+) its own pose) against the truth.
Errors ErrorsOf(const std::vector<OriginSample>& samples, const std::vector<NodeView>& nodes,
                const std::vector<Pose2>& truth) {
  Errors e;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Pose2 map = Compose(OriginAt(samples, nodes[i].stamp), nodes[i].global);
    const double d = std::hypot(map.x - truth[i].x, map.y - truth[i].y);
    e.max = std::max(e.max, d);
    e.last = d;
  }
  return e;
}

class TrajectoryFollowTest : public ::testing::Test {
 protected:
  void SetUp() override {
    walls_ = PillarOffice();
    // Robot 1 defines the map frame (its start is the map's origin): its truth relative to it.
    const std::vector<Pose2> a = PolylinePath(
        {{2.0, 4.5}, {12.0, 4.5}, {12.0, 7.0}, {3.0, 7.0}, {3.0, 9.0}, {8.0, 10.5}}, 0.25);
    map_ = {TiedTrajectory{Pose2{}, DriftingNodes(walls_, a, 1.0, 0.0)}};
    b_ = PolylinePath({{15.5, 6.5}, {6.0, 6.5}, {5.0, 4.0}, {13.0, 5.5}, {15.5, 8.0}}, 0.25);
    for (const Pose2& p : b_) truth_.push_back(Relative(a.front(), p));  // in the map frame
    // Robot 2 drifts: 1.5 % long, 0.004 rad per node to the left.
    nodes_ = DriftingNodes(walls_, b_, 1.015, 0.004);
    // Tied in at its first node, right there (as TrajectoryTie ties in: 2-7 cm on real logs).
    tie_ = OriginSample{nodes_.front().scan, nodes_.front().stamp,
                        Compose(truth_.front(), Invert(nodes_.front().global))};
  }

  std::vector<Wall> walls_;
  std::vector<Pose2> b_;  // robot 2's true poses in the world
  std::vector<TiedTrajectory> map_;
  std::vector<Pose2> truth_;
  std::vector<NodeView> nodes_;
  OriginSample tie_;
};

TEST_F(TrajectoryFollowTest, FollowUpMatchesKeepADriftingRobotOnTheMap) {
  // Without follow-up: one fixed origin, the drift carries the robot off the map.
  const Errors fixed = ErrorsOf({tie_}, nodes_, truth_);
  EXPECT_GT(fixed.max, 0.5) << "the synthetic drift is too small to test anything";

  absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
      TrajectoryFollow::Create(FollowOptions{}, tie_);
  ASSERT_TRUE(follow.ok()) << follow.status();
  size_t map_nodes = map_.front().nodes.size();
  ASSERT_TRUE((*follow)->WantsMap(map_nodes));
  ASSERT_TRUE((*follow)->SetMap(MapCloud(map_, 0.05), map_nodes).ok());
  // The nodes arrive one at a time, as the robot drives; one attempt a call at most.
  std::vector<NodeView> seen;
  for (const NodeView& node : nodes_) {
    seen.push_back(node);
    (*follow)->Advance(seen, 1);
  }
  const FollowProgress& progress = (*follow)->progress();
  EXPECT_LE(progress.attempts, static_cast<int>(nodes_.size()) / FollowOptions{}.every_nodes + 1);
  EXPECT_GE(progress.matched, progress.attempts / 2)
      << "weak " << progress.weak << ", ambiguous " << progress.ambiguous;
  EXPECT_EQ((*follow)->samples().size(), static_cast<size_t>(progress.matched) + 1);
  const Errors followed = ErrorsOf((*follow)->samples(), nodes_, truth_);
  EXPECT_LT(followed.max, 0.08) << "fixed origin: max " << fixed.max;
  EXPECT_LT(followed.last, 0.08);
}

// The server's --slam-map-follow-windows narrow: the travel's windows alone keep the drifting
// robot on the map too.
TEST_F(TrajectoryFollowTest, TheNarrowWindowsKeepADriftingRobotOnTheMap) {
  const FollowOptions options = NarrowFollowWindows();
  EXPECT_FALSE(options.window_from_uncertainty);
  absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
      TrajectoryFollow::Create(options, tie_);
  ASSERT_TRUE(follow.ok()) << follow.status();
  const size_t map_nodes = map_.front().nodes.size();
  ASSERT_TRUE((*follow)->SetMap(MapCloud(map_, 0.05), map_nodes, MapPath(map_)).ok());
  std::vector<NodeView> seen;
  for (const NodeView& node : nodes_) {
    seen.push_back(node);
    (*follow)->Advance(seen, 1);
  }
  const FollowProgress& progress = (*follow)->progress();
  EXPECT_GE(progress.matched, progress.attempts / 2)
      << "weak " << progress.weak << ", ambiguous " << progress.ambiguous;
  const Errors followed = ErrorsOf((*follow)->samples(), nodes_, truth_);
  EXPECT_LT(followed.max, 0.08);
  EXPECT_LT(followed.last, 0.08);
}

// The window is searched as a box, but a match in its corner lies farther from where the last
// sample puts the robot than the uncertainty reaches: with the uncertainty's windows it is
// refused (a look-alike a few metres off). Here the map is the first robot's shifted 1.2 m in x
// and in y (1.7 m) and the window reaches about 1.6 m: inside the box, outside the circle.
TEST_F(TrajectoryFollowTest, AMatchInTheWindowsCornerIsBeyondTheUncertainty) {
  PointCloud shifted;
  AppendTransformed(MapCloud(map_, 0.05), Pose2{1.2, 1.2, 0.0}, &shifted);
  const auto follow_with = [&](FollowOptions options) {
    options.sigma_xy_floor = 0.5;  // windows of about 1.6 m from the first attempt on
    absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
        TrajectoryFollow::Create(options, tie_);
    EXPECT_TRUE(follow.ok()) << follow.status();
    EXPECT_TRUE((*follow)->SetMap(shifted, map_.front().nodes.size(), MapPath(map_)).ok());
    std::vector<NodeView> seen(nodes_.begin(), nodes_.begin() + 6);
    (*follow)->Advance(seen, 1);
    return *std::move(follow);
  };
  // The travel's windows take the shifted copy.
  const std::unique_ptr<TrajectoryFollow> travel = follow_with(NarrowFollowWindows());
  ASSERT_EQ(travel->progress().matched, 1);
  EXPECT_NEAR(travel->samples().back().map_pose.x - truth_[5].x, 1.2, 0.1);
  // The uncertainty's (the default) refuse it.
  const std::unique_ptr<TrajectoryFollow> gated = follow_with(FollowOptions{});
  EXPECT_EQ(gated->progress().attempts, 1);
  EXPECT_EQ(gated->progress().matched, 0);
  EXPECT_EQ(gated->progress().beyond, 1);
}

// How often the robot is looked at goes by its travel too, not by its nodes alone: a log that
// keeps one scan per metre (the corrected logs of ../shared) makes every scan a node, and
// every_nodes of them span four times the travel they span in a raw log. Where the nodes lie
// 0.25 m apart (the session's node_travel) the travel changes nothing.
TEST_F(TrajectoryFollowTest, ALogWithAScanPerMetreIsLookedAtAsOftenPerMetre) {
  const auto attempts = [&](const std::vector<NodeView>& nodes, const std::vector<Pose2>& truth,
                            FollowOptions options) {
    const OriginSample tie{nodes.front().scan, nodes.front().stamp,
                           Compose(truth.front(), Invert(nodes.front().global))};
    absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
        TrajectoryFollow::Create(options, tie);
    EXPECT_TRUE(follow.ok()) << follow.status();
    EXPECT_TRUE((*follow)->SetMap(MapCloud(map_, 0.05), map_.front().nodes.size()).ok());
    std::vector<NodeView> seen;
    for (const NodeView& node : nodes) {
      seen.push_back(node);
      (*follow)->Advance(seen, 1);
    }
    EXPECT_GE((*follow)->progress().matched, (*follow)->progress().attempts / 2)
        << "weak " << (*follow)->progress().weak << " ambiguous " << (*follow)->progress().ambiguous
        << " beyond " << (*follow)->progress().beyond;
    return (*follow)->progress().attempts;
  };
  FollowOptions nodes_only;
  nodes_only.every_metres = 0.0;
  // The fixture's nodes, 0.25 m apart (1.5 % long): the same attempts either way.
  EXPECT_EQ(attempts(nodes_, truth_, FollowOptions{}), attempts(nodes_, truth_, nodes_only));
  // One node per metre of the same drive, drifting as much per metre as a node of the fixture
  // drifts per metre in length, a quarter as much in heading (a query spanning 4 m bent by
  // 0.016 rad per metre finds nothing).
  std::vector<Pose2> world, sparse_truth;
  for (size_t i = 0; i < b_.size(); i += 4) {
    world.push_back(b_[i]);
    sparse_truth.push_back(truth_[i]);
  }
  const std::vector<NodeView> sparse = DriftingNodes(walls_, world, 1.015, 0.004);
  const int by_nodes = attempts(sparse, sparse_truth, nodes_only);
  const int by_travel = attempts(sparse, sparse_truth, FollowOptions{});
  EXPECT_GE(by_nodes, 3);
  // Every second node (2 m >= 1.25 m) instead of every fifth.
  EXPECT_GE(by_travel, 2 * by_nodes);
  EXPECT_LE(by_travel, static_cast<int>(sparse.size()) / 2 + 1);
}

// A node its session pruned keeps no points. An attempt whose query has too few points is not an
// attempt: the next node with points is tried at once, not every_nodes later, so how often the
// robot is matched does not depend on what its session had pruned when the follow got there.
TEST_F(TrajectoryFollowTest, AnAttemptOnPrunedNodesMovesOnToTheNextNode) {
  std::vector<NodeView> nodes = nodes_;
  const auto no_points = std::make_shared<const PointCloud>();
  for (int i = 1; i <= 11; ++i) nodes[i].points = no_points;
  FollowOptions options;
  options.every_metres = 0.0;  // every 5 nodes: 5 and 10 fall on the pruned ones
  absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
      TrajectoryFollow::Create(options, tie_);
  ASSERT_TRUE(follow.ok()) << follow.status();
  ASSERT_TRUE((*follow)->SetMap(MapCloud(map_, 0.05), map_.front().nodes.size()).ok());
  std::vector<NodeView> seen;
  for (size_t i = 0; i < 18; ++i) {
    seen.push_back(nodes[i]);
    (*follow)->Advance(seen, 1);
  }
  // Node 12 (its own points), then five nodes on: 17.
  ASSERT_EQ((*follow)->progress().attempts, 2);
  ASSERT_EQ((*follow)->progress().matched, 2);
  EXPECT_EQ((*follow)->samples()[1].scan, nodes[12].scan);
  EXPECT_EQ((*follow)->samples()[2].scan, nodes[17].scan);
}

// A follow stopped half-way (its server restarted, or another server took the map over) and
// resumed from its stored samples matches only the nodes after them, and ends with the samples of
// a follow never interrupted.
TEST_F(TrajectoryFollowTest, AResumedFollowGoesOnWhereTheStoredOneStopped) {
  const size_t map_nodes = map_.front().nodes.size();
  const PointCloud map = MapCloud(map_, 0.05);
  const auto follow_from = [&](absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow,
                               size_t first, size_t last) {
    EXPECT_TRUE(follow.ok()) << follow.status();
    EXPECT_TRUE((*follow)->SetMap(map, map_nodes).ok());
    std::vector<NodeView> seen(nodes_.begin(), nodes_.begin() + first);
    for (size_t i = first; i < last; ++i) {
      seen.push_back(nodes_[i]);
      (*follow)->Advance(seen, 1);
    }
    return *std::move(follow);
  };
  const std::unique_ptr<TrajectoryFollow> whole =
      follow_from(TrajectoryFollow::Create(FollowOptions{}, tie_), 0, nodes_.size());
  const size_t half = nodes_.size() / 2;
  const std::unique_ptr<TrajectoryFollow> first =
      follow_from(TrajectoryFollow::Create(FollowOptions{}, tie_), 0, half);
  ASSERT_GT(first->samples().size(), 2u);
  const std::unique_ptr<TrajectoryFollow> resumed = follow_from(
      TrajectoryFollow::Resume(FollowOptions{}, first->samples()), half, nodes_.size());
  // Only the nodes after the last stored sample are matched again.
  EXPECT_EQ(first->progress().attempts + resumed->progress().attempts, whole->progress().attempts);
  ASSERT_EQ(resumed->samples().size(), whole->samples().size());
  for (size_t i = 0; i < whole->samples().size(); ++i) {
    EXPECT_EQ(resumed->samples()[i].scan, whole->samples()[i].scan) << i;
    EXPECT_NEAR(resumed->samples()[i].origin.x, whole->samples()[i].origin.x, 1e-9) << i;
    EXPECT_NEAR(resumed->samples()[i].origin.theta, whole->samples()[i].origin.theta, 1e-9) << i;
  }
  EXPECT_FALSE(TrajectoryFollow::Resume(FollowOptions{}, {}).ok());
}

TEST_F(TrajectoryFollowTest, NothingToMatchAgainstLeavesTheTieAlone) {
  // A map far from where the robot is: every window misses it, no sample, the tie held.
  std::vector<TiedTrajectory> elsewhere = map_;
  elsewhere.front().origin = Pose2{100.0, 100.0, 0.0};
  absl::StatusOr<std::unique_ptr<TrajectoryFollow>> follow =
      TrajectoryFollow::Create(FollowOptions{}, tie_);
  ASSERT_TRUE(follow.ok());
  ASSERT_TRUE((*follow)->SetMap(MapCloud(elsewhere, 0.05), 1).ok());
  for (int i = 0; i < 10; ++i) (*follow)->Advance(nodes_, 100);
  EXPECT_EQ((*follow)->samples().size(), 1u);
  EXPECT_EQ((*follow)->progress().matched, 0);
  EXPECT_GT((*follow)->progress().weak, 0);
}

TEST(OriginAtTest, InterpolatesBetweenSamplesAndHoldsOutside) {
  const std::vector<OriginSample> samples{{1, 10.0, Pose2{0.0, 0.0, 3.1}},
                                          {5, 20.0, Pose2{1.0, -2.0, -3.1}}};
  EXPECT_DOUBLE_EQ(OriginAt(samples, 0.0).x, 0.0);
  EXPECT_DOUBLE_EQ(OriginAt(samples, 99.0).y, -2.0);
  const Pose2 mid = OriginAt(samples, 15.0);
  EXPECT_DOUBLE_EQ(mid.x, 0.5);
  EXPECT_DOUBLE_EQ(mid.y, -1.0);
  // The shorter way round: 3.1 -> -3.1 passes through pi, not 0.
  EXPECT_NEAR(std::abs(mid.theta), M_PI, 1e-9);
  EXPECT_EQ(OriginAt({}, 5.0).x, 0.0);
  FollowOptions bad;
  bad.every_nodes = 0;
  EXPECT_FALSE(TrajectoryFollow::Create(bad, samples.front()).ok());
  bad = FollowOptions{};
  bad.every_metres = std::nan("");
  EXPECT_FALSE(TrajectoryFollow::Create(bad, samples.front()).ok());
}

// A matched sample's origin follows its node: the session's own closure moved the node after the
// match, and the map-frame pose the match observed stays where it was.
TEST(RefreshOriginsTest, AMatchedSampleFollowsItsNodeAndTheTieStays) {
  const Pose2 tie_origin{1.0, 2.0, 0.3};
  const Pose2 map_pose{5.0, -1.0, 1.2};
  NodeView moved;
  moved.scan = 7;
  moved.stamp = 3.5;
  moved.global = Pose2{2.0, 0.5, 0.4};  // where the node is now, after a closure
  NodeView first;
  first.scan = 1;
  first.global = Pose2{0.0, 0.0, 0.0};
  std::vector<OriginSample> samples{{1, 0.0, tie_origin},
                                    {7, 3.5, Pose2{9.0, 9.0, 0.0}, true, map_pose},
                                    {9, 4.0, Pose2{-3.0, 0.0, 0.0}, true, map_pose}};
  RefreshOrigins({first, moved}, &samples);
  EXPECT_DOUBLE_EQ(samples[0].origin.x, tie_origin.x);  // not a match: kept
  const Pose2 again = Compose(samples[1].origin, moved.global);
  EXPECT_NEAR(again.x, map_pose.x, 1e-12);
  EXPECT_NEAR(again.y, map_pose.y, 1e-12);
  EXPECT_NEAR(again.theta, map_pose.theta, 1e-12);
  EXPECT_DOUBLE_EQ(samples[2].origin.x, -3.0);  // its node is not among the nodes: kept
}

}  // namespace
}  // namespace waymark::laser_slam

namespace waymark::laser_slam {
namespace {

// The window grows with the travel since the last sample, three sigmas of the floor plus the
// drift per metre, up to its caps.
TEST(FollowWindowTest, GrowsWithTheTravelUpToItsCaps) {
  const FollowOptions options;
  const SearchWindow none = FollowWindow(options, 0.0);
  EXPECT_DOUBLE_EQ(none.xy, 3.0 * 0.1);
  EXPECT_DOUBLE_EQ(none.theta, 3.0 * 0.03);
  const SearchWindow after_20m = FollowWindow(options, 20.0);
  EXPECT_DOUBLE_EQ(after_20m.xy, 3.0 * (0.1 + 0.02 * 20.0));
  EXPECT_DOUBLE_EQ(after_20m.theta, 3.0 * (0.03 + 0.005 * 20.0));
  const SearchWindow far = FollowWindow(options, 1e6);
  EXPECT_DOUBLE_EQ(far.xy, options.max_window_xy);
  EXPECT_DOUBLE_EQ(far.theta, options.max_window_theta);
}

// Two places close together in the map but at the two ends of one robot's loop are that loop
// apart along the map; places nearest to two different robots' nodes, nothing (the tie and the
// samples relate those, not a path).
// The server's --slam-map-follow-windows wide: the map's drift in the window and caps of 30 m and
// 1.5 rad, every other option as given.
TEST(FollowWindowTest, TheWideWindowsReachAsFarAsTheMapMayHaveDrifted) {
  FollowOptions custom;
  custom.min_score = 0.7;
  const FollowOptions wide = WideFollowWindows(custom);
  EXPECT_TRUE(ValidateFollowOptions(wide).ok());
  EXPECT_TRUE(wide.window_for_map_drift);
  EXPECT_FALSE(wide.window_from_uncertainty);
  EXPECT_EQ(wide.min_score, 0.7);
  // 200 m of travel (the robot's and the map's path): 3 x (0.1 + 0.02 x 200) m, where the
  // default windows stop at 2 m.
  EXPECT_NEAR(FollowWindow(wide, 200.0).xy, 12.3, 1e-9);
  EXPECT_DOUBLE_EQ(FollowWindow(FollowOptions{}, 200.0).xy, 2.0);
  EXPECT_NEAR(FollowWindow(wide, 1000.0).theta, 1.5, 1e-12);
}

// A robot's nodes along a 10 m x 4 m loop it did not close, 0.5 m apart: its start at (0, 0),
// its end at (0, 0.5), each step with `step_sigma`.
std::vector<NodeView> OpenLoopNodes(const Eigen::Vector3d& step_sigma = Eigen::Vector3d::Zero()) {
  const std::vector<Pose2> loop = PolylinePath({{0, 0}, {10, 0}, {10, 4}, {0, 4}, {0, 0.5}}, 0.5);
  std::vector<NodeView> nodes;
  for (size_t i = 0; i < loop.size(); ++i) {
    NodeView node;
    node.scan = i + 1;
    node.global = loop[i];
    node.step_sigma = step_sigma;
    nodes.push_back(node);
  }
  return nodes;
}

TEST(FollowWindowTest, TheMapsPathBetweenTwoPlacesIsAlongOneTrajectory) {
  // Robot 0 drives the open loop; robot 1 stands 20 m east.
  std::vector<TiedTrajectory> map(2);
  map[0].nodes = OpenLoopNodes();
  const size_t loop_size = map[0].nodes.size();
  for (int i = 0; i < 5; ++i) {
    NodeView node;
    node.scan = i + 1;
    node.global = Pose2{20.0 + i, 0.0, 0.0};
    map[1].nodes.push_back(node);
  }
  const std::vector<MapPathPoint> path = MapPath(map);
  ASSERT_EQ(path.size(), loop_size + 5);
  EXPECT_NEAR(path[loop_size - 1].along, 10.0 + 4.0 + 10.0 + 3.0, 0.5);
  EXPECT_EQ(path.back().trajectory, 1);
  EXPECT_NEAR(path.back().along, 4.0, 1e-9);
  // The loop's start and end: 0.5 m apart in the map, 27 m along it.
  EXPECT_NEAR(MapTravelBetween(path, Pose2{0.1, 0.0, 0.0}, Pose2{0.1, 0.6, 0.0}), 27.0, 0.6);
  EXPECT_NEAR(MapTravelBetween(path, Pose2{5.0, 0.1, 0.0}, Pose2{6.0, 0.1, 0.0}), 1.0, 1e-9);
  EXPECT_DOUBLE_EQ(MapTravelBetween(path, Pose2{5.0, 0.0, 0.0}, Pose2{21.0, 0.0, 0.0}), 0.0);
  EXPECT_DOUBLE_EQ(MapTravelBetween({}, Pose2{}, Pose2{1.0, 0.0, 0.0}), 0.0);

  // Had robot 0's session closed its loop (its last node with its first), the two ends are one
  // place of its map: the way round the loop no longer counts.
  GraphConstraint closure;
  closure.kind = GraphConstraint::Kind::kLoop;
  closure.from = static_cast<int>(loop_size) - 1;
  closure.to = 0;
  map[0].loops = {closure};
  const std::vector<MapPathPoint> closed = MapPath(map);
  EXPECT_NEAR(MapTravelBetween(closed, Pose2{0.1, 0.0, 0.0}, Pose2{0.1, 0.6, 0.0}), 0.0, 1e-9);
  // Half way round, the shorter way counts: (10, 2) is 12 m from the start one way and 15 m the
  // other; from the start's neighbour (1, 0), 11 m.
  EXPECT_NEAR(MapTravelBetween(closed, Pose2{1.0, 0.1, 0.0}, Pose2{10.1, 2.0, 0.0}), 11.0, 1e-9);
}

// The map's uncertainty between two places: each chain step on the way adds its xy variance and
// its heading variance swung over the distance to the end; a loop its session closed is one
// place; no one trajectory holding both ends, nothing.
TEST(FollowWindowTest, TheMapsUncertaintyBetweenTwoPlacesAddsUpItsStepsOnTheWay) {
  const double xy = 0.02, theta = 0.004;
  std::vector<TiedTrajectory> map(1);
  map[0].nodes = OpenLoopNodes(Eigen::Vector3d(xy, xy, theta));
  std::vector<Pose2> loop;
  for (const NodeView& node : map[0].nodes) loop.push_back(node.global);
  const std::vector<MapPathPoint> path = MapPath(map);
  ASSERT_EQ(path[1].step_sigma, Eigen::Vector3d(xy, xy, theta));
  // Along the first side from (0, 0) to (5, 0): ten steps, the k-th swung over 5 - 0.5 k metres.
  double want = 0.0;
  for (int k = 0; k < 10; ++k) want += xy * xy + theta * theta * std::pow(5.0 - 0.5 * k, 2);
  const ChainUncertainty::Sigma side = MapUncertaintyBetween(path, Pose2{}, Pose2{5.0, 0.0, 0.0});
  EXPECT_NEAR(side.xy, std::sqrt(want), 1e-9);
  EXPECT_NEAR(side.theta, theta * std::sqrt(10.0), 1e-9);
  // The open loop's two ends, 0.5 m apart in the map: every step of the way round, each swung
  // over its distance to the end searched.
  const Pose2 end{0.1, 0.6, 0.0};
  double round = 0.0;
  for (size_t k = 0; k + 1 < loop.size(); ++k) {
    round +=
        xy * xy + theta * theta * (std::pow(end.x - loop[k].x, 2) + std::pow(end.y - loop[k].y, 2));
  }
  const ChainUncertainty::Sigma open = MapUncertaintyBetween(path, Pose2{0.1, 0.0, 0.0}, end);
  EXPECT_NEAR(open.xy, std::sqrt(round), 1e-9);
  EXPECT_GT(open.xy, 10.0 * MapUncertaintyBetween(path, Pose2{}, Pose2{0.5, 0.0, 0.0}).xy);
  // Closed by its session: the two ends are one place.
  GraphConstraint closure;
  closure.kind = GraphConstraint::Kind::kLoop;
  closure.from = static_cast<int>(loop.size()) - 1;
  closure.to = 0;
  map[0].loops = {closure};
  const ChainUncertainty::Sigma closed =
      MapUncertaintyBetween(MapPath(map), Pose2{0.1, 0.0, 0.0}, Pose2{0.1, 0.6, 0.0});
  EXPECT_NEAR(closed.xy, 0.0, 1e-12);
  EXPECT_NEAR(closed.theta, 0.0, 1e-12);
  const ChainUncertainty::Sigma none = MapUncertaintyBetween({}, Pose2{}, Pose2{1.0, 0.0, 0.0});
  EXPECT_EQ(none.xy, 0.0);
}

// Across trajectories the way goes through the nodes a follow sample (or the tie) matched to
// another trajectory's: robot 1 drove 10 m along y = -1.5 and was tied in at its end, 1.5 m from
// robot 0's loop at (10, 0). Without that sample, or with robot 1 farther than the 2 m a sample's
// node is related within, nothing relates the two.
TEST(FollowWindowTest, TheMapsUncertaintyGoesAcrossRobotsThroughTheirSamples) {
  const double xy = 0.02, theta = 0.004;
  std::vector<TiedTrajectory> map(2);
  map[0].nodes = OpenLoopNodes(Eigen::Vector3d(xy, xy, theta));
  for (int i = 0; i <= 20; ++i) {
    NodeView node;
    node.scan = i + 1;
    node.stamp = i;
    node.global = Pose2{0.5 * i, -1.5, 0.0};
    node.step_sigma = Eigen::Vector3d(xy, xy, theta);
    map[1].nodes.push_back(node);
  }
  const Pose2 from{0.0, -1.5, 0.0}, to{10.0, 1.0, 0.0};
  EXPECT_EQ(MapUncertaintyBetween(MapPath(map), from, to).xy, 0.0);
  map[1].samples = {OriginSample{21, 20.0, Pose2{}}};
  // Robot 1's 20 steps, then robot 0's two from (10, 0) to (10, 1), each swung to the end.
  double want = 0.0;
  for (int i = 0; i < 20; ++i)
    want += xy * xy + theta * theta * (std::pow(10.0 - 0.5 * i, 2) + 6.25);
  want += 2 * xy * xy + theta * theta * (1.0 + 0.25);
  EXPECT_NEAR(MapUncertaintyBetween(MapPath(map), from, to).xy, std::sqrt(want), 1e-9);
  // The wide windows' path length stays within one trajectory.
  EXPECT_EQ(MapTravelBetween(MapPath(map), from, to), 0.0);
  // Robot 1 3 m from the loop: too far for its sample's node to be related.
  for (NodeView& node : map[1].nodes) node.global.y = -3.0;
  EXPECT_EQ(MapUncertaintyBetween(MapPath(map), Pose2{0.0, -3.0, 0.0}, to).xy, 0.0);
}

}  // namespace
}  // namespace waymark::laser_slam

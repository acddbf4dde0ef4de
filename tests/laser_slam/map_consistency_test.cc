// The map self-check (server/laser_slam/mapping/map_consistency.h) on synthetic maps with known
// answers: a robot drives twice around a loop of corridors; its nodes at the true poses are a
// clean map, the same nodes with the second lap rotated about where it began are a folded one
// (a wrong loop closure), and people walking past the robot, a few stray returns or a cart parked
// during one lap leave the clean map clean. The real logs' verdicts are in docs/laser-slam.md
// ("A map that checks itself").

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "server/laser_slam/mapping/map_consistency.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::CastScan;
using testing::Lms200Geometry;
using testing::RayCastOptions;
using testing::Wall;

// A 2 m wide corridor around a 16 m x 8 m block, with two rooms off the outer walls (doorways
// 1 m wide): the kind of floor a robot maps twice over.
std::vector<Wall> CorridorLoop() {
  std::vector<Wall> walls = Box(2.0, 2.0, 18.0, 10.0);  // the block
  // Outer wall, broken by the doorways at x in [5, 6] (south) and [13, 14] (north).
  const std::vector<Wall> outer = {
      {{0, 0}, {5, 0}},   {{6, 0}, {20, 0}},   {{20, 0}, {20, 12}},
      {{20, 12}, {14, 12}}, {{13, 12}, {0, 12}}, {{0, 12}, {0, 0}},
  };
  walls.insert(walls.end(), outer.begin(), outer.end());
  // The rooms behind the doorways.
  const std::vector<Wall> rooms = {
      {{3, 0}, {3, -4}},  {{3, -4}, {8, -4}},  {{8, -4}, {8, 0}},
      {{11, 12}, {11, 16}}, {{11, 16}, {16, 16}}, {{16, 16}, {16, 12}},
  };
  walls.insert(walls.end(), rooms.begin(), rooms.end());
  return walls;
}

// Poses every 0.25 m along the corridor's centre line, `laps` times around, heading along it.
std::vector<Pose2> LapPoses(int laps) {
  const std::vector<Eigen::Vector2d> corners = {{1, 1}, {19, 1}, {19, 11}, {1, 11}};
  std::vector<Pose2> poses;
  for (int lap = 0; lap < laps; ++lap) {
    for (size_t i = 0; i < corners.size(); ++i) {
      const Eigen::Vector2d a = corners[i], b = corners[(i + 1) % corners.size()];
      const double length = (b - a).norm();
      const double heading = std::atan2(b.y() - a.y(), b.x() - a.x());
      for (double d = 0.0; d < length; d += 0.25) {
        const Eigen::Vector2d p = a + (b - a) * (d / length);
        poses.push_back({p.x(), p.y(), heading});
      }
    }
  }
  return poses;
}

// A node's points as the back end keeps them: returns within 12 m, one per 5 cm cell.
NodeView NodeAt(const std::vector<Wall>& walls, const Pose2& pose, std::uint64_t scan,
                std::mt19937* rng) {
  RayCastOptions ray;
  ray.sensor_range = 12.0;
  ray.range_sigma = 0.01;  // the LMS200's centimetre
  const LaserScan cast = CastScan(walls, pose, Lms200Geometry(), ray, rng);
  NodeView node;
  node.scan = scan;
  node.stamp = static_cast<double>(scan);
  node.global = pose;
  node.points = std::make_shared<const PointCloud>(
      ThinPoints(ScanToPoints(cast, Pose2{}, 0.05, 12.0), 0.05));
  return node;
}

std::vector<NodeView> CleanMap(int laps = 2) {
  const std::vector<Wall> walls = CorridorLoop();
  std::mt19937 rng(7);
  std::vector<NodeView> nodes;
  for (const Pose2& pose : LapPoses(laps)) {
    nodes.push_back(NodeAt(walls, pose, nodes.size() + 1, &rng));
  }
  return nodes;
}

// Nodes [first, end) moved as a wrong loop closure moves them: rotated by `angle` about the
// position of node `first`.
void Fold(std::vector<NodeView>& nodes, size_t first, size_t end, double angle) {
  const Eigen::Vector2d pivot(nodes[first].global.x, nodes[first].global.y);
  const Eigen::Rotation2Dd rotation(angle);
  for (size_t i = first; i < end; ++i) {
    const Eigen::Vector2d p =
        pivot + rotation * (Eigen::Vector2d(nodes[i].global.x, nodes[i].global.y) - pivot);
    nodes[i].global = {p.x(), p.y(), nodes[i].global.theta + angle};
  }
}

TEST(MapConsistencyTest, TheCleanLoopIsConsistent) {
  const std::vector<NodeView> nodes = CleanMap();
  ASSERT_GT(nodes.size(), 300u);  // 2 laps of 56 m: 18 submaps, the second lap over the first
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->consistent) << report->verdict;
  EXPECT_EQ(report->submaps, static_cast<int>((nodes.size() + 24) / 25));
  // The second lap confirms the first almost everywhere: there is evidence, and it agrees.
  EXPECT_GT(report->confirmed, 1000) << report->verdict;
  EXPECT_LT(report->fraction, 0.01) << report->verdict;
  EXPECT_EQ(report->tiles_contradicting, 0);
}

TEST(MapConsistencyTest, HalfTheMapRotatedBy25DegreesContradictsItself) {
  std::vector<NodeView> nodes = CleanMap();
  Fold(nodes, nodes.size() / 2, nodes.size(), 25.0 * M_PI / 180.0);
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_FALSE(report->consistent) << report->verdict;
  EXPECT_GT(report->tiles_contradicting, 0) << report->verdict;
  EXPECT_GT(report->fraction, 0.1) << report->verdict;
  // The cells to draw are where the rotated lap's walls cross the first lap's corridors: inside
  // the loop's corridors or the block, not only at its edges.
  EXPECT_GT(report->contradicting_cells.size(), 50u);
}

TEST(MapConsistencyTest, AWrongClosureThatSwingsTheLastCorridorIsFoundWhereItIs) {
  // A smaller fold: the second lap's last 20 m (the west half of the north corridor and the west
  // corridor) swung by 25 degrees about where they begin, as one wrong closure would. Most of
  // the map is right; the areas that contradict themselves are where the swung part lies.
  std::vector<NodeView> nodes = CleanMap();
  const size_t swung = nodes.size() - 80;
  Fold(nodes, swung, nodes.size(), 25.0 * M_PI / 180.0);
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_FALSE(report->consistent) << report->verdict;
  ASSERT_GE(report->tiles_contradicting, 2) << report->verdict;
  for (const ConsistencyTile& tile : report->tiles) {
    if (!tile.contradicts) continue;
    // The swung part starts at x = 10 m on the north corridor and swings south-west.
    EXPECT_LT(tile.min.x(), 12.0) << "tile at " << tile.min.transpose();
  }
}

// The scale of what the check calls a contradiction (issue 33, "Every map, looked at" in
// docs/results.md): the benchmark's noisy-odometry maps that fail are the ones whose overlapping
// submaps are misregistered, against the corrected poses, by 0.47 m or more at 5 m; belgioioso's
// low row (relations 0.043 m on average) fails because its last submap, back at the start, lies
// 1.3 m off the first. Here the last submap (23 nodes down the west corridor, over the first lap)
// moved sideways as that row's was: 1.3 m is a corridor drawn twice, a map that contradicts
// itself where the moved submap lies; 0.15 m (a registration blur, inside the tolerance) is not.
void Shift(std::vector<NodeView>& nodes, size_t first, double dx, double dy) {
  for (size_t i = first; i < nodes.size(); ++i) {
    nodes[i].global.x += dx;
    nodes[i].global.y += dy;
  }
}

TEST(MapConsistencyTest, TheLastSubmapDrawnAMetreOffTheStartContradictsItselfThere) {
  std::vector<NodeView> nodes = CleanMap();
  const size_t last_submap = (nodes.size() - 1) / 25 * 25;
  ASSERT_LT(last_submap, nodes.size());
  for (size_t i = last_submap; i < nodes.size(); ++i) {
    ASSERT_NEAR(nodes[i].global.x, 1.0, 1e-9);  // the west corridor
  }
  Shift(nodes, last_submap, 1.3, 0.0);
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_FALSE(report->consistent) << report->verdict;
  for (const ConsistencyTile& tile : report->tiles) {
    if (tile.contradicts) {
      EXPECT_LT(tile.min.x(), 5.0) << "tile at " << tile.min.transpose();
    }
  }
}

TEST(MapConsistencyTest, TheLastSubmapFifteenCentimetresOffIsABlurNotAContradiction) {
  std::vector<NodeView> nodes = CleanMap();
  Shift(nodes, (nodes.size() - 1) / 25 * 25, 0.15, 0.0);
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->consistent) << report->verdict;
  EXPECT_EQ(report->tiles_contradicting, 0) << report->verdict;
}

TEST(MapConsistencyTest, ACartParkedInOneLapIsAChangeOfTheWorldNotAFold) {
  // A 1.5 m cart against the south wall during the first lap only: the first lap's submaps hold
  // a wall where the second lap saw free space, but nothing of the second lap stands in the first
  // lap's free space there. One-sided: counted, not held against the map.
  const std::vector<Wall> walls = CorridorLoop();
  std::mt19937 rng(5);
  std::vector<NodeView> nodes;
  const std::vector<Pose2> poses = LapPoses(2);
  for (size_t i = 0; i < poses.size(); ++i) {
    std::vector<Wall> scene = walls;
    if (i < poses.size() / 2) {
      for (const Wall& w : Box(9.0, 0.05, 10.5, 0.6)) scene.push_back(w);
    }
    nodes.push_back(NodeAt(scene, poses[i], i + 1, &rng));
  }
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->consistent) << report->verdict;
  EXPECT_GT(report->one_sided, 10) << report->verdict;
  EXPECT_EQ(report->contradicted, 0) << report->verdict;
}

TEST(MapConsistencyTest, TheIncrementalCheckerCastsOnlyWhatMovedAndAgreesWithAFreshCheck) {
  std::vector<NodeView> nodes = CleanMap();
  MapConsistencyChecker checker;
  absl::StatusOr<MapConsistencyReport> first = checker.Check(nodes);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->submaps_cast, first->submaps);

  // Unmoved: nothing is cast again, and the answer is the same.
  absl::StatusOr<MapConsistencyReport> again = checker.Check(nodes);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->submaps_cast, 0);
  EXPECT_EQ(again->contradicted, first->contradicted);
  EXPECT_EQ(again->confirmed, first->confirmed);

  // The second half folded: its submaps (and the one it starts in) are cast again, and the
  // answer is a fresh check's.
  Fold(nodes, nodes.size() / 2, nodes.size(), 25.0 * M_PI / 180.0);
  absl::StatusOr<MapConsistencyReport> folded = checker.Check(nodes);
  absl::StatusOr<MapConsistencyReport> fresh = CheckMapConsistency(nodes);
  ASSERT_TRUE(folded.ok() && fresh.ok());
  EXPECT_LT(folded->submaps_cast, folded->submaps);
  EXPECT_GE(folded->submaps_cast, folded->submaps / 2);
  EXPECT_FALSE(folded->consistent);
  EXPECT_EQ(folded->contradicted, fresh->contradicted);
  EXPECT_EQ(folded->confirmed, fresh->confirmed);
  EXPECT_EQ(folded->contradicting_cells.size(), fresh->contradicting_cells.size());
}

TEST(MapConsistencyTest, PeopleWalkingAndStrayReturnsDoNotFailACleanMap) {
  const std::vector<Wall> walls = CorridorLoop();
  std::mt19937 rng(11);
  std::vector<NodeView> nodes;
  const std::vector<Pose2> poses = LapPoses(2);
  for (size_t i = 0; i < poses.size(); ++i) {
    std::vector<Wall> scene = walls;
    // A person (two legs, 0.15 m each) walking towards the robot along the south corridor
    // during the first lap, 0.4 m per node, and one walking away from it along the north
    // corridor in the second lap, 0.2 m per node (the robot does 0.25 m).
    if (i >= 10 && i < 60) {
      const double x = 19.0 - 0.4 * (i - 10);
      for (const Wall& w : Box(x, 0.6, x + 0.15, 0.75)) scene.push_back(w);
      for (const Wall& w : Box(x + 0.3, 0.7, x + 0.45, 0.85)) scene.push_back(w);
    }
    if (i >= 336 && i < 400) {
      const double x = 15.0 - 0.2 * (i - 336);
      for (const Wall& w : Box(x, 11.2, x + 0.15, 11.35)) scene.push_back(w);
      for (const Wall& w : Box(x + 0.3, 11.3, x + 0.45, 11.45)) scene.push_back(w);
    }
    NodeView node = NodeAt(scene, poses[i], i + 1, &rng);
    // Every 20th scan, three returns from nowhere in the corridor ahead (dust, a glint).
    if (i % 20 == 0) {
      PointCloud points = *node.points;
      std::uniform_real_distribution<double> ahead(1.0, 6.0), across(-0.8, 0.8);
      for (int k = 0; k < 3; ++k) {
        points.emplace_back(static_cast<float>(ahead(rng)), static_cast<float>(across(rng)));
      }
      node.points = std::make_shared<const PointCloud>(std::move(points));
    }
    nodes.push_back(std::move(node));
  }
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(nodes);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->consistent) << report->verdict;
  EXPECT_EQ(report->tiles_contradicting, 0) << report->verdict;
}

TEST(MapConsistencyTest, ASingleLapHasNothingToContradict) {
  // One lap: each corridor is seen by one stretch of submaps and their neighbours, so apart from
  // where the lap closes on its start there is little evidence and no contradiction.
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(CleanMap(1));
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_TRUE(report->consistent) << report->verdict;
  EXPECT_EQ(report->contradicted, 0) << report->verdict;
}

TEST(MapConsistencyTest, NoNodesIsConsistentAndBadOptionsAreRefused) {
  absl::StatusOr<MapConsistencyReport> empty = CheckMapConsistency({});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->consistent);
  EXPECT_EQ(empty->submaps, 0);

  MapConsistencyOptions options;
  options.submap_nodes = 0;
  EXPECT_EQ(CheckMapConsistency(CleanMap(1), options).status().code(),
            absl::StatusCode::kInvalidArgument);
  options = MapConsistencyOptions{};
  options.resolution = -0.1;
  EXPECT_EQ(CheckMapConsistency(CleanMap(1), options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(MapConsistencyTest, AMapTooLargeForTheCellBudgetIsCheckedCoarser) {
  MapConsistencyOptions options;
  options.max_cells = 20'000;  // the loop's ~30 m x 24 m at 10 cm needs 72 000
  absl::StatusOr<MapConsistencyReport> report = CheckMapConsistency(CleanMap(), options);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_GT(report->resolution, 0.1);
  EXPECT_TRUE(report->consistent) << report->verdict;
}

}  // namespace
}  // namespace waymark::laser_slam

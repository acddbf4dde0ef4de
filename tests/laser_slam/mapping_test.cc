// The loop-closing back end (server/laser_slam/mapping): pose graph, likelihood grids and
// branch-and-bound matching, occupancy grids, localization, checkpoints. Synthetic data with known
// answers; the real logs are in tests/realdata.

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/localizer.h"
#include "server/laser_slam/mapping/ekf_step_agreement.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/pose_graph.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::CastScan;
using testing::Lms200Geometry;
using testing::RayCastOptions;
using testing::Wall;

// An L-shaped room with a pillar: no symmetry, so a scan has one pose in it.
std::vector<Wall> LRoom() {
  std::vector<Wall> walls = {
      {{0, 0}, {10, 0}}, {{10, 0}, {10, 4}}, {{10, 4}, {4, 4}},
      {{4, 4}, {4, 9}},  {{4, 9}, {0, 9}},   {{0, 9}, {0, 0}},
  };
  for (const Wall& w : Box(6.5, 1.5, 7.0, 2.2)) walls.push_back(w);
  return walls;
}

PointCloud PointsFrom(const std::vector<Wall>& walls, const Pose2& pose) {
  return testing::ScanPoints(walls, pose);
}

// ---- pose graph ------------------------------------------------------------------------------

struct SquareLoop {
  std::vector<Pose2> truth;
  std::vector<Pose2> drifted;  // dead reckoning of the biased chain
  std::vector<GraphConstraint> constraints;
};

// A robot drives a 10 m square, one node every metre; the chain's measured steps turn 0.01 rad
// too much per step, so the chained poses drift; the last node sees the first (a true closure).
SquareLoop MakeSquareLoop() {
  SquareLoop loop;
  Pose2 pose;
  for (int side = 0; side < 4; ++side) {
    for (int i = 0; i < 10; ++i) {
      loop.truth.push_back(pose);
      const bool corner = i == 9;
      pose = Compose(pose, Pose2{1.0, 0.0, corner ? M_PI / 2 : 0.0});
    }
  }
  loop.truth.push_back(pose);  // back at the start
  loop.drifted.push_back(loop.truth.front());
  for (size_t i = 1; i < loop.truth.size(); ++i) {
    GraphConstraint chain;
    chain.from = static_cast<int>(i) - 1;
    chain.to = static_cast<int>(i);
    chain.relative = Relative(loop.truth[i - 1], loop.truth[i]);
    chain.relative.theta += 0.01;  // the bias
    chain.sigma = Eigen::Vector3d(0.05, 0.05, 0.02);
    loop.constraints.push_back(chain);
    loop.drifted.push_back(Compose(loop.drifted.back(), chain.relative));
  }
  GraphConstraint closure;
  closure.kind = GraphConstraint::Kind::kLoop;
  closure.from = 0;
  closure.to = static_cast<int>(loop.truth.size()) - 1;
  closure.relative = Relative(loop.truth.front(), loop.truth.back());
  closure.sigma = Eigen::Vector3d(0.01, 0.01, 0.005);
  loop.constraints.push_back(closure);
  return loop;
}

double WorstError(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::hypot(a[i].x - b[i].x, a[i].y - b[i].y));
  return worst;
}

TEST(PoseGraphTest, ASquareLoopWithItsClosureRecoversTheTruth) {
  SquareLoop loop = MakeSquareLoop();
  std::vector<Pose2> poses = loop.drifted;
  const double before = WorstError(poses, loop.truth);
  ASSERT_GT(before, 2.0);  // 40 steps of 0.01 rad: metres off at the far corner
  const GraphSolveReport report = SolvePoseGraph(poses, loop.constraints, GraphSolveOptions{});
  EXPECT_LT(report.final_cost, report.initial_cost);
  // The bias is spread over the loop: what remains is the inconsistency of a 0.01 rad bias per
  // step, a few centimetres, against metres before.
  EXPECT_LT(WorstError(poses, loop.truth), 0.15) << "before: " << before;
  // The first node is the gauge.
  EXPECT_EQ(poses.front().x, 0.0);
  EXPECT_EQ(poses.front().theta, 0.0);
}

TEST(PoseGraphTest, AWrongClosureIsSwitchedOffAndTheRightOneKept) {
  SquareLoop loop = MakeSquareLoop();
  // A second closure, 3 m and 0.5 rad off, from the middle of the second side to the start.
  GraphConstraint wrong = loop.constraints.back();
  wrong.to = 15;
  wrong.relative = Relative(loop.truth.front(), loop.truth[15]);
  wrong.relative.x += 3.0;
  wrong.relative.theta += 0.5;
  loop.constraints.push_back(wrong);
  std::vector<Pose2> poses = loop.drifted;
  const int switched_off =
      SolveRejectingOutliers(poses, loop.constraints, GraphSolveOptions{}, /*outlier_residual=*/5.0);
  EXPECT_EQ(switched_off, 1);
  EXPECT_FALSE(loop.constraints.back().enabled);
  EXPECT_TRUE(loop.constraints[loop.constraints.size() - 2].enabled);
  EXPECT_LT(WorstError(poses, loop.truth), 0.15);

  // Without the switch-off the Huber loss only bounds the damage: the map is bent.
  std::vector<Pose2> bent = loop.drifted;
  for (GraphConstraint& c : loop.constraints) c.enabled = true;
  SolvePoseGraph(bent, loop.constraints, GraphSolveOptions{});
  EXPECT_GT(WorstError(bent, loop.truth), WorstError(poses, loop.truth));
}

// ---- grids and matching ----------------------------------------------------------------------

TEST(LikelihoodGridTest, PyramidLevelsHoldTheMaximumOfTheirWindow) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  PointCloud points;
  for (int i = 0; i < 40; ++i) points.emplace_back(u(rng), u(rng));
  const LikelihoodGrid grid = BuildLikelihoodGrid(points, 0.05, 0.05);
  const SearchPyramid pyramid(grid, 3);
  ASSERT_EQ(pyramid.depth(), 3);
  for (int level = 0; level <= 3; ++level) {
    const int w = 1 << level;
    for (int y = -w; y < grid.height; y += 7) {
      for (int x = -w; x < grid.width; x += 5) {
        std::uint8_t expected = 0;
        for (int dy = 0; dy < w; ++dy) {
          for (int dx = 0; dx < w; ++dx) expected = std::max(expected, grid.At(x + dx, y + dy));
        }
        ASSERT_EQ(pyramid.At(level, x, y), expected) << "level " << level << " at " << x << "," << y;
      }
    }
  }
  // The field peaks on the points and falls off away from them.
  EXPECT_GT(grid.Interpolate(points[0].x(), points[0].y()), 0.8);
  EXPECT_EQ(grid.Interpolate(100.0, 100.0), 0.0);
}

TEST(CorrelativeMatcherTest, FindsTheScanPoseInTheMapWithinTheWindow) {
  const std::vector<Wall> room = LRoom();
  const Pose2 truth{2.3, 2.1, 0.4};
  const PointCloud map_points = TransformPoints(PointsFrom(room, Pose2{5.0, 1.5, 2.5}), Pose2{5.0, 1.5, 2.5});
  PointCloud all = map_points;
  AppendTransformed(PointsFrom(room, Pose2{1.5, 6.0, -1.2}), Pose2{1.5, 6.0, -1.2}, &all);
  const SearchPyramid map(BuildLikelihoodGrid(ThinPoints(all, 0.05), 0.05, 0.05), 6);
  const PointCloud scan = ThinPoints(PointsFrom(room, truth), 0.05);
  // Start 0.8 m and 0.25 rad away.
  const Pose2 guess{truth.x + 0.6, truth.y - 0.5, truth.theta - 0.25};
  const std::optional<GridMatch> match = MatchInWindow(map, scan, guess, SearchWindow{1.0, 0.4}, 0.5);
  ASSERT_TRUE(match.has_value());
  // Within a cell: the map's points sit where its own beams fell, not where this scan's do.
  EXPECT_NEAR(match->pose.x, truth.x, 0.05);
  EXPECT_NEAR(match->pose.y, truth.y, 0.05);
  EXPECT_NEAR(match->pose.theta, truth.theta, 0.02);
  EXPECT_GT(match->score, 0.5);

  // Branch and bound finds what the exhaustive search (depth 0) finds, with fewer candidates.
  const SearchPyramid flat(BuildLikelihoodGrid(ThinPoints(all, 0.05), 0.05, 0.05), 0);
  const std::optional<GridMatch> exhaustive = MatchInWindow(flat, scan, guess, SearchWindow{1.0, 0.4}, 0.5);
  ASSERT_TRUE(exhaustive.has_value());
  EXPECT_NEAR(exhaustive->pose.x, match->pose.x, 1e-9);
  EXPECT_NEAR(exhaustive->pose.y, match->pose.y, 1e-9);
  EXPECT_NEAR(exhaustive->pose.theta, match->pose.theta, 1e-9);
  EXPECT_LT(match->candidates * 5, exhaustive->candidates);

  // Outside the window, or above any score it reaches: nothing, never a wrong pose.
  EXPECT_FALSE(MatchInWindow(map, scan, Pose2{truth.x + 3, truth.y, truth.theta}, SearchWindow{0.5, 0.1}, 0.8));
  EXPECT_FALSE(MatchInWindow(map, scan, guess, SearchWindow{1.0, 0.4}, 0.999));
}

TEST(OccupancyGridTest, WallsAreOccupiedTheRoomFreeAndTheOutsideUnknown) {
  const std::vector<Wall> room = Box(0, 0, 6, 4);
  std::vector<NodeView> nodes;
  for (const Pose2& p : {Pose2{1.5, 2.0, 0.0}, Pose2{4.5, 2.0, M_PI}}) {
    nodes.push_back(NodeView{1, 0.0, p, std::make_shared<const PointCloud>(PointsFrom(room, p))});
  }
  absl::StatusOr<OccupancyGrid> grid = RenderOccupancy(nodes, 0.05);
  ASSERT_TRUE(grid.ok()) << grid.status();
  const auto at = [&](double x, double y) {
    return grid->At(static_cast<int>(std::floor((x - grid->origin.x()) / 0.05)),
                    static_cast<int>(std::floor((y - grid->origin.y()) / 0.05)));
  };
  // The most occupied of the cells around (x, y): a wall point may fall either side of a border.
  const auto wall_at = [&](double x, double y) {
    int best = -1;
    for (double dx : {-0.05, 0.0, 0.05}) {
      for (double dy : {-0.05, 0.0, 0.05}) best = std::max<int>(best, at(x + dx, y + dy));
    }
    return best;
  };
  EXPECT_LE(at(3.0, 2.0), 19);      // the middle of the room: free by map_server's 0.196
  EXPECT_GE(at(3.0, 2.0), 0);
  EXPECT_GE(wall_at(3.0, 0.0), 65);  // the bottom wall
  EXPECT_GE(wall_at(6.0, 2.0), 65);  // the right wall
  EXPECT_EQ(at(3.0, -0.07), -1);     // behind the wall (the grid's margin): never seen
  // The grid spans the points with a small margin.
  EXPECT_LT(grid->origin.x(), 0.0);
  EXPECT_GT(grid->origin.x() + grid->width * 0.05, 6.0);
  EXPECT_NEAR(grid->width * 0.05, 6.0, 0.3);

  // Occupied cells back as points: on the walls.
  const PointCloud occupied = OccupiedPoints(*grid);
  ASSERT_FALSE(occupied.empty());
  for (const Eigen::Vector2f& p : occupied) {
    const double to_wall = std::min({std::abs(p.x()), std::abs(p.x() - 6.0f), std::abs(p.y()),
                                     std::abs(p.y() - 4.0f)});
    EXPECT_LT(to_wall, 0.1) << p.transpose();
  }

  // A cell budget picks a coarser resolution that fits it.
  const double coarser = ResolutionThatFits(nodes, 0.05, 2000);
  EXPECT_GT(coarser, 0.05);
  absl::StatusOr<OccupancyGrid> small = RenderOccupancy(nodes, coarser, 2000);
  ASSERT_TRUE(small.ok()) << small.status();
  EXPECT_LE(static_cast<std::int64_t>(small->width) * small->height, 2000);
  EXPECT_EQ(ResolutionThatFits(nodes, 0.05, 1'000'000), 0.05);

  // A map too large for the resolution is refused with the resolution that fits.
  nodes.push_back(NodeView{2, 0.0, Pose2{900.0, 900.0, 0.0}, nodes[0].points});
  absl::StatusOr<OccupancyGrid> huge = RenderOccupancy(nodes, 0.05);
  EXPECT_EQ(huge.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(huge.status().message().find("resolution of at least"), std::string::npos);
}

// ---- localization ----------------------------------------------------------------------------

PointCloud LRoomMap() {
  PointCloud map;
  for (const Pose2& p : {Pose2{2.0, 2.0, 0.0}, Pose2{7.0, 2.0, M_PI}, Pose2{2.0, 7.0, -M_PI / 2}}) {
    AppendTransformed(PointsFrom(LRoom(), p), p, &map);
  }
  return map;
}

TEST(MapLocalizerTest, AnUnknownStartIsFoundByTwoAgreeingGlobalSearches) {
  LocalizationOptions options;  // no initial pose
  // Each global search whole within its scan (localizer_test.cc spreads them over scans).
  options.global_reads_per_scan = std::int64_t{1} << 50;
  absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer = MapLocalizer::Create(options, LRoomMap());
  ASSERT_TRUE(localizer.ok()) << localizer.status();
  // The robot starts at an unknown pose; its local frame is its start.
  const Pose2 start{2.5, 3.0, 0.8};
  LocalizationResult result;
  std::uint64_t scan = 0;
  for (int i = 0; i < 4; ++i) {
    const Pose2 local{0.3 * i, 0.0, 0.0};
    const Pose2 truth = Compose(start, local);
    result = (*localizer)->AddScan(++scan, i, local, PointsFrom(LRoom(), truth));
    if (i == 0) {
      EXPECT_TRUE(result.global_search);
      EXPECT_FALSE(result.localized);  // one match is not enough
    }
  }
  ASSERT_TRUE(result.localized);
  const Pose2 found = (*localizer)->ToMap(scan, Pose2{0.9, 0.0, 0.0});
  const Pose2 truth = Compose(start, Pose2{0.9, 0.0, 0.0});
  EXPECT_NEAR(found.x, truth.x, 0.05);
  EXPECT_NEAR(found.y, truth.y, 0.05);
  EXPECT_NEAR(found.theta, truth.theta, 0.02);
  // Retroactively, the first scans are in the map frame too.
  EXPECT_NEAR((*localizer)->ToMap(1, Pose2{}).x, start.x, 0.05);

  // Tracking: a local motion 3 % long (the EKF's, which is better than the wheels') is corrected
  // by each match.
  Pose2 local{0.9, 0.0, 0.0};
  Pose2 truth_pose = truth;
  for (int i = 0; i < 6; ++i) {
    truth_pose = Compose(truth_pose, Pose2{0.3, 0.0, 0.05});
    local = Compose(local, Pose2{0.309, 0.0, 0.05});
    result = (*localizer)->AddScan(++scan, 10 + i, local, PointsFrom(LRoom(), truth_pose));
    EXPECT_TRUE(result.localized);
    EXPECT_FALSE(result.global_search);
  }
  const Pose2 tracked = (*localizer)->ToMap(scan, local);
  EXPECT_NEAR(tracked.x, truth_pose.x, 0.05);
  EXPECT_NEAR(tracked.y, truth_pose.y, 0.05);
}

TEST(MapLocalizerTest, AKnownStartIsFixedOnceFiveScansAreInAndTheStateSurvivesACheckpoint) {
  LocalizationOptions options;
  const Pose2 start{7.5, 1.0, 2.0};
  options.initial_pose = Pose2{7.3, 1.2, 1.9};  // 0.3 m and 0.1 rad off, within 3 sigma
  absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer = MapLocalizer::Create(options, LRoomMap());
  ASSERT_TRUE(localizer.ok());
  // Dead reckoning from the given start until five scans can be matched together, never a
  // global search.
  LocalizationResult result;
  for (int i = 0; i < 5; ++i) {
    const Pose2 local{0.3 * i, 0.0, 0.0};
    result = (*localizer)->AddScan(i + 1, i, local, PointsFrom(LRoom(), Compose(start, local)));
    EXPECT_FALSE(result.global_search);
    EXPECT_EQ(result.localized, i == 4) << i;
  }
  EXPECT_EQ(result.fixes, 1);
  EXPECT_NEAR((*localizer)->ToMap(1, Pose2{}).x, start.x, 0.05);
  EXPECT_NEAR((*localizer)->ToMap(1, Pose2{}).y, start.y, 0.05);

  absl::StatusOr<std::unique_ptr<MapLocalizer>> resumed = MapLocalizer::Create(options, LRoomMap());
  ASSERT_TRUE(resumed.ok());
  ASSERT_TRUE((*resumed)->Restore((*localizer)->Serialize()).ok());
  EXPECT_TRUE((*resumed)->last().localized);
  EXPECT_NEAR((*resumed)->ToMap(1, Pose2{}).x, (*localizer)->ToMap(1, Pose2{}).x, 1e-12);
  std::string bytes = (*localizer)->Serialize();
  EXPECT_EQ((*resumed)->Restore(bytes.substr(0, bytes.size() - 3)).code(),
            absl::StatusCode::kDataLoss);

  EXPECT_EQ(MapLocalizer::Create(options, PointCloud{}).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

// A checkpoint is read back from storage: a correction beyond any map is corrupt bytes, refused
// like the pose graph's (input_bounds.h).
TEST(MapLocalizerTest, ACheckpointWithACorrectionBeyondAnyMapIsRefused) {
  LocalizationOptions options;
  const Pose2 start{7.5, 1.0, 2.0};
  options.initial_pose = Pose2{7.3, 1.2, 1.9};
  absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer = MapLocalizer::Create(options, LRoomMap());
  ASSERT_TRUE(localizer.ok());
  for (int i = 0; i < 5; ++i) {
    const Pose2 local{0.3 * i, 0.0, 0.0};
    (*localizer)->AddScan(i + 1, i, local, PointsFrom(LRoom(), Compose(start, local)));
  }
  const std::string bytes = (*localizer)->Serialize();
  // Magic and version (4 bytes each), two flags, the last node's pose, two travels and a stamp
  // (8 bytes each), the fixes and the count (4 each); then the first correction's scan number
  // and its x.
  constexpr size_t kFirstCorrectionX = 4 + 4 + 2 + 6 * 8 + 4 + 4 + 8;
  ASSERT_GE(bytes.size(), kFirstCorrectionX + sizeof(double));
  const auto restore_with_x = [&](double x) {
    std::string changed = bytes;
    changed.replace(kFirstCorrectionX, sizeof(x), reinterpret_cast<const char*>(&x), sizeof(x));
    absl::StatusOr<std::unique_ptr<MapLocalizer>> resumed = MapLocalizer::Create(options, LRoomMap());
    return resumed.ok() ? (*resumed)->Restore(changed).code() : resumed.status().code();
  };
  EXPECT_EQ(restore_with_x(1e300), absl::StatusCode::kDataLoss);
  EXPECT_EQ(restore_with_x(7.0), absl::StatusCode::kOk);  // the offset is the correction's x
}

// ---- the back end in a session ---------------------------------------------------------------

TEST(MappingBackendTest, NodesFollowTheTravelAndTheCheckpointRestoresTheGraph) {
  MappingOptions options;
  options.submap_nodes = 3;
  // The same scan at every pose: local matching would (rightly) say the robot stood still.
  options.local_matching = false;
  MappingBackend backend(options);
  const PointCloud points = PointsFrom(LRoom(), Pose2{2, 2, 0});
  std::uint64_t scan = 0;
  for (int i = 0; i < 20; ++i) backend.AddScan(++scan, i, Pose2{0.05 * i, 0, 0}, points);
  // 0.95 m of travel, a node every 0.25 m: the first scan and then every fifth.
  EXPECT_EQ(backend.Stats().nodes, 4);
  EXPECT_EQ(backend.Stats().submaps, 2);
  // Between nodes a local pose maps through the correction of the node before it.
  const Pose2 p = backend.ToGlobal(7, Pose2{0.3, 0.0, 0.0});
  EXPECT_NEAR(p.x, 0.3, 1e-12);

  absl::StatusOr<std::unique_ptr<MappingBackend>> restored =
      MappingBackend::Deserialize(options, backend.Serialize());
  ASSERT_TRUE(restored.ok()) << restored.status();
  EXPECT_EQ((*restored)->Serialize(), backend.Serialize());
  EXPECT_EQ((*restored)->Nodes().size(), 4u);
  const std::string bytes = backend.Serialize();
  EXPECT_EQ(MappingBackend::Deserialize(options, bytes.substr(0, bytes.size() - 1)).status().code(),
            absl::StatusCode::kDataLoss);
  EXPECT_EQ(MappingBackend::Deserialize(options, "garbage").status().code(),
            absl::StatusCode::kDataLoss);
}

// A checkpoint is read back from storage: a number beyond any map is corrupt bytes, refused, not a
// place. A stored scan point of -5e37 m made the loop search turn it into a grid index beyond the
// integers' range (undefined behaviour; found by make fuzz).
TEST(MappingBackendTest, ACheckpointWithAPointOrPoseBeyondAnyMapIsRefused) {
  MappingOptions options;
  options.submap_nodes = 3;
  MappingBackend backend(options);
  const PointCloud points = PointsFrom(LRoom(), Pose2{2, 2, 0});
  for (int i = 0; i < 20; ++i) backend.AddScan(i + 1, i, Pose2{0.05 * i, 0, 0}, points);
  const std::string bytes = backend.Serialize();
  // The first node follows the magic, the version and the node count (4 bytes each): its scan
  // number, stamp and travel, its local and global poses (8 bytes each), its point count (4),
  // then its points (two floats each).
  constexpr size_t kNode = 12;
  constexpr size_t kGlobalX = kNode + 3 * 8 + 3 * 8;
  constexpr size_t kFirstPoint = kNode + 9 * 8 + 4;
  const auto deserialize_with = [&](size_t at, auto value) {
    std::string changed = bytes;
    changed.replace(at, sizeof(value), reinterpret_cast<const char*>(&value), sizeof(value));
    return MappingBackend::Deserialize(options, changed).status().code();
  };
  EXPECT_EQ(deserialize_with(kFirstPoint, -5e37f), absl::StatusCode::kDataLoss);
  EXPECT_EQ(deserialize_with(kGlobalX, 1e300), absl::StatusCode::kDataLoss);
  // The offsets are right: plausible values there load.
  EXPECT_EQ(deserialize_with(kFirstPoint, -5.0f), absl::StatusCode::kOk);
  EXPECT_EQ(deserialize_with(kGlobalX, 3.0), absl::StatusCode::kOk);
}

// Version 2 stores the newest node processed (nodes still waiting for the thread are processed
// after a resume); version 3 the odometry of every node and the loop search's state. A version-1
// checkpoint, without them, still loads, every node counted processed and its EKF poses taken for
// the odometry.
TEST(MappingBackendTest, AVersionOneCheckpointStillLoads) {
  MappingOptions options;
  options.submap_nodes = 3;
  MappingBackend backend(options);
  const PointCloud points = PointsFrom(LRoom(), Pose2{2, 2, 0});
  for (int i = 0; i < 20; ++i) backend.AddScan(i + 1, i, Pose2{0.05 * i, 0, 0}, points);
  const std::string v3 = backend.Serialize();  // the current version (6)
  // Version 1 from the current one: each node without its odometry (a pose and three variances after
  // its points) nor version 6's pruning (a flag, two node indices, two poses, a weight and three
  // sigmas), each submap without version 6's flags, and the end without the processed index, nor
  // version 3's three int32 and three poses' worth of doubles (dead reckoning, motion variance,
  // last local pose), nor version 4's front end state, nor version 5's count of pending closures
  // (none here), nor version 6's count of coverage cells (none: nothing pruned).
  constexpr size_t kHeader = 3 * sizeof(std::uint32_t);
  constexpr size_t kNodeFixed = 8 + 8 + 8 + 2 * 24;  // scan, stamp, travel, local, global
  constexpr size_t kOdometry = 6 * sizeof(double) + 1 + 2 * 4 + 2 * 24 + 8 + 3 * sizeof(double);
  std::uint32_t count = 0;
  std::memcpy(&count, v3.data() + 2 * sizeof(std::uint32_t), sizeof(count));
  std::string v1 = v3.substr(0, kHeader);
  size_t at = kHeader;
  for (std::uint32_t n = 0; n < count; ++n) {
    std::uint32_t cloud = 0;
    std::memcpy(&cloud, v3.data() + at + kNodeFixed, sizeof(cloud));
    const size_t node = kNodeFixed + sizeof(cloud) + cloud * 2 * sizeof(float);
    v1 += v3.substr(at, node);
    at += node + kOdometry;
  }
  constexpr size_t kV3Tail = 3 * sizeof(std::int32_t) + 9 * sizeof(double);
  constexpr size_t kV4Tail = EkfStepAgreement::kValues * sizeof(double) + 1;  // the front end's
  constexpr size_t kV5Tail = 2 * sizeof(std::uint32_t);  // no pending closure, no coverage
  const size_t processed_at = v3.size() - kV5Tail - kV4Tail - kV3Tail - 7 * sizeof(std::int32_t);
  std::uint32_t submaps = 0;
  std::memcpy(&submaps, v3.data() + at, sizeof(submaps));
  v1 += v3.substr(at, sizeof(submaps));
  at += sizeof(submaps);
  for (std::uint32_t m = 0; m < submaps; ++m) {
    std::uint32_t frozen = 0;
    std::memcpy(&frozen, v3.data() + at + 9, sizeof(frozen));
    const size_t submap = 9 + sizeof(frozen) + frozen * 24;  // first, count, complete, poses
    v1 += v3.substr(at, submap);
    at += submap + 1;  // version 6's flags
  }
  v1 += v3.substr(at, processed_at - at);
  v1 += v3.substr(processed_at + sizeof(std::int32_t), 6 * sizeof(std::int32_t));
  const std::uint32_t one = 1;
  v1.replace(sizeof(std::uint32_t), sizeof(one), reinterpret_cast<const char*>(&one), sizeof(one));
  absl::StatusOr<std::unique_ptr<MappingBackend>> restored = MappingBackend::Deserialize(options, v1);
  ASSERT_TRUE(restored.ok()) << restored.status();
  EXPECT_EQ((*restored)->Serialize().size(), v3.size());
  ASSERT_EQ((*restored)->Nodes().size(), backend.Nodes().size());
  for (size_t i = 0; i < backend.Nodes().size(); ++i) {
    EXPECT_EQ((*restored)->Nodes()[i].global.x, backend.Nodes()[i].global.x);
  }
  // A processed index beyond the nodes is refused.
  std::string beyond = v3;
  const std::int32_t too_far = 4;
  beyond.replace(processed_at, sizeof(too_far), reinterpret_cast<const char*>(&too_far),
                 sizeof(too_far));
  EXPECT_EQ(MappingBackend::Deserialize(options, beyond).status().code(),
            absl::StatusCode::kDataLoss);
}

TEST(MappingBackendTest, TheThreadedBackEndAgreesWithTheInlineOneAfterFlush) {
  MappingOptions inline_options, threaded_options;
  threaded_options.threads = 1;
  MappingBackend inline_backend(inline_options), threaded(threaded_options);
  std::uint64_t scan = 0;
  for (int i = 0; i < 60; ++i) {
    const Pose2 pose{0.1 * i, 0.0, 0.0};
    const PointCloud points = PointsFrom(LRoom(), Compose(Pose2{1.0, 1.0, 0.0}, pose));
    ++scan;
    inline_backend.AddScan(scan, i, pose, points);
    threaded.AddScan(scan, i, pose, points);
  }
  threaded.Flush();
  EXPECT_EQ(threaded.Stats().pending_nodes, 0);
  EXPECT_EQ(threaded.Stats().nodes, inline_backend.Stats().nodes);
  EXPECT_EQ(threaded.Serialize(), inline_backend.Serialize());
}

}  // namespace
}  // namespace waymark::laser_slam

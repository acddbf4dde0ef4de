// The goal layer's grid parts (issue 17; server/laser_slam/exploration/): what one scan marks in
// the exploration grid and how the grid grows, frontier extraction on hand-made maps (closed
// room, side opening, gaps in a wall, open corridor end), and grid paths (round an obstacle,
// through doorways, never through unknown space, out of a tight spot). goal_layer_test.cc tests
// the goal layer that uses them.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/exploration/exploration_grid.h"
#include "server/laser_slam/exploration/frontiers.h"
#include "server/laser_slam/exploration/grid_paths.h"
#include "tests/laser_slam/engine_loop.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::CastScan;
using testing::DistanceToWalls;
using testing::Lms200OneDegreeGeometry;
using testing::RayCastOptions;
using testing::W;
using testing::Wall;

constexpr double kCell = 0.1;  // the default grid resolution, used by every hand-made grid

// ---------------------------------------------------------------------------------------------
// Helpers: hand-made grids.

// Marks every cell whose centre lies in [x0, x1] x [y0, y1] (m). Hand-made maps give cell
// centres (k + 0.5) * kCell, so that no cell is ambiguous.
void Fill(ExplorationGrid* grid, double x0, double y0, double x1, double y1, GridCell cell) {
  const int ix0 = static_cast<int>(std::ceil(x0 / kCell - 0.5 - 1e-6));
  const int ix1 = static_cast<int>(std::floor(x1 / kCell - 0.5 + 1e-6));
  const int iy0 = static_cast<int>(std::ceil(y0 / kCell - 0.5 - 1e-6));
  const int iy1 = static_cast<int>(std::floor(y1 / kCell - 0.5 + 1e-6));
  for (int iy = iy0; iy <= iy1; ++iy) {
    for (int ix = ix0; ix <= ix1; ++ix) {
      grid->Set(kCell * Eigen::Vector2d(ix + 0.5, iy + 0.5), cell);
    }
  }
}

// The cell under `p` (unknown outside the grid).
GridCell CellAt(const ExplorationGrid& grid, const Eigen::Vector2d& p) {
  const Eigen::Vector2i c = grid.CellOf(p);
  return grid.Inside(c.x(), c.y()) ? grid.At(c.x(), c.y()) : GridCell::kUnknown;
}

// Euclidean distance from `p` to the nearest occupied cell centre, by brute force: the reference
// for the planner's chamfer distances.
double DistanceToOccupied(const ExplorationGrid& grid, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) {
      if (grid.At(x, y) != GridCell::kOccupied) continue;
      best = std::min(best, (grid.Centre(x, y) - p).norm());
    }
  }
  return best;
}

// A room with walls one cell thick all round its free interior [0, w] x [0, h] (m).
ExplorationGrid WalledRoom(double w, double h) {
  ExplorationGrid grid(kCell);
  Fill(&grid, -0.05, -0.05, w + 0.05, h + 0.05, GridCell::kOccupied);
  Fill(&grid, 0.05, 0.05, w - 0.05, h - 0.05, GridCell::kFree);
  return grid;
}

// The 1-degree LMS200 with a no-return marker a float holds exactly. Its own 8.183 m is no float:
// a no-return stored in a scan's float ranges reads 8.1829996 and counts as a return (beyond
// max_range, which the grid treats like a no-return anyway); here a no-return must be one.
ScanGeometry ExactNoReturnGeometry() {
  ScanGeometry g = Lms200OneDegreeGeometry();
  g.no_return_range = 8.0;
  return g;
}

// ---------------------------------------------------------------------------------------------
// The exploration grid: what one scan marks, and growth.

// One scan integrated into an empty grid: two walls, ahead and to the left; the beams that miss
// both have no return. Where each beam ended, and the cells it passed through (sampled every
// 2 mm).
class ExplorationGridScanTest : public ::testing::Test {
 protected:
  static constexpr double kMaxRange = 6.0, kFreeRange = 3.0, kBody = 0.3;

  ExplorationGridScanTest() {
    const LaserScan scan = CastScan(walls_, robot_, ExactNoReturnGeometry(), RayCastOptions{},
                                    nullptr);
    grid_.Integrate(robot_, Pose2{}, scan, kMaxRange, kFreeRange, kBody);
    const Eigen::Vector2d from(robot_.x, robot_.y);
    crossed_.assign(static_cast<size_t>(grid_.width()) * grid_.height(), 0);
    for (int i = 0; i < scan.geometry.beam_count; ++i) {
      const double b = robot_.theta + scan.geometry.angle_min + i * scan.geometry.angle_increment;
      const bool hit = IsReturn(scan.ranges[i], scan.geometry) && scan.ranges[i] < kMaxRange;
      const Eigen::Vector2d end =
          from + (hit ? scan.ranges[i] : kFreeRange) * Eigen::Vector2d(std::cos(b), std::sin(b));
      if (hit) returns_.push_back(end);
      const int samples = static_cast<int>((end - from).norm() / 0.002);
      for (int k = 0; k <= samples; ++k) {
        const Eigen::Vector2i c = grid_.CellOf(from + (end - from) * (double(k) / samples));
        if (grid_.Inside(c.x(), c.y())) crossed_[grid_.Index(c.x(), c.y())] = 1;
      }
    }
  }

  // Whether a beam passed through the cell or a neighbour (sampling may miss a clipped corner).
  bool NearBeam(int x, int y) const {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (grid_.Inside(x + dx, y + dy) && crossed_[grid_.Index(x + dx, y + dy)]) return true;
      }
    }
    return false;
  }
  bool InBody(const Eigen::Vector2d& c) const {
    return (c - Eigen::Vector2d(robot_.x, robot_.y)).norm() <= kBody;
  }

  const std::vector<Wall> walls_ = {W(2.03, -1.0, 2.03, 1.5), W(-1.0, 1.53, 1.0, 1.53)};
  const Pose2 robot_{0.31, 0.22, 0.4};
  ExplorationGrid grid_{kCell};
  std::vector<Eigen::Vector2d> returns_;
  std::vector<char> crossed_;
};

TEST_F(ExplorationGridScanTest, ReturnsAreOccupiedAndNothingElseIs) {
  ASSERT_GT(returns_.size(), 60u);
  ASSERT_LT(returns_.size(), 181u) << "some beams must have no return";
  for (const Eigen::Vector2d& r : returns_) {
    EXPECT_EQ(CellAt(grid_, r), GridCell::kOccupied) << "return at " << r.transpose();
  }
  for (int y = 0; y < grid_.height(); ++y) {
    for (int x = 0; x < grid_.width(); ++x) {
      if (grid_.At(x, y) != GridCell::kOccupied) continue;
      const bool has_return = std::any_of(returns_.begin(), returns_.end(), [&](const auto& r) {
        return grid_.CellOf(r) == Eigen::Vector2i(x, y);
      });
      EXPECT_TRUE(has_return) << "occupied without a return at " << grid_.Centre(x, y).transpose();
    }
  }
}

TEST_F(ExplorationGridScanTest, CrossedCellsAndTheBodyAreFreeAndNothingElseIsKnown) {
  int known = 0;
  for (int y = 0; y < grid_.height(); ++y) {
    for (int x = 0; x < grid_.width(); ++x) {
      const Eigen::Vector2d c = grid_.Centre(x, y);
      const GridCell cell = grid_.At(x, y);
      // Crossed by a beam and no wall passes through it (farther than half a diagonal).
      if ((crossed_[grid_.Index(x, y)] && DistanceToWalls(walls_, c) > 0.5 * M_SQRT2 * kCell) ||
          InBody(c)) {
        EXPECT_EQ(cell, GridCell::kFree) << c.transpose();
      }
      if (cell == GridCell::kUnknown) continue;
      ++known;
      EXPECT_TRUE(InBody(c) || NearBeam(x, y)) << "known, no beam came near: " << c.transpose();
    }
  }
  EXPECT_GT(known, 500);
  // Behind the robot (the laser sees ahead only) and beyond the walls nothing is known.
  const Eigen::Vector2d ahead(std::cos(robot_.theta), std::sin(robot_.theta));
  EXPECT_EQ(CellAt(grid_, Eigen::Vector2d(robot_.x, robot_.y) - 0.6 * ahead), GridCell::kUnknown);
  EXPECT_EQ(CellAt(grid_, Eigen::Vector2d(2.4, 0.5)), GridCell::kUnknown);
  EXPECT_EQ(CellAt(grid_, Eigen::Vector2d(0.0, 1.9)), GridCell::kUnknown);
}

TEST(ExplorationGridTest, NoReturnFreesUpToFreeRangeAndNoFurther) {
  LaserScan scan;
  scan.geometry = ExactNoReturnGeometry();
  scan.ranges.assign(181, static_cast<float>(scan.geometry.no_return_range));
  ASSERT_FALSE(IsReturn(scan.ranges[0], scan.geometry));
  const Pose2 robot{0.0, 0.0, 0.0};
  ExplorationGrid grid(kCell);
  grid.Integrate(robot, Pose2{}, scan, /*max_range=*/6.0, /*free_range=*/3.0, /*body_radius=*/0.3);
  int occupied = 0;
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) occupied += grid.At(x, y) == GridCell::kOccupied;
  }
  EXPECT_EQ(occupied, 0);
  for (int i = 0; i < 181; i += 10) {
    const double b = scan.geometry.angle_min + i * scan.geometry.angle_increment;
    const Eigen::Vector2d d(std::cos(b), std::sin(b));
    // Cells holding a point 2.85 m out lie wholly within 3 m, those at 3.15 m wholly beyond.
    EXPECT_EQ(CellAt(grid, 2.85 * d), GridCell::kFree) << "beam " << i;
    EXPECT_EQ(CellAt(grid, 3.15 * d), GridCell::kUnknown) << "beam " << i;
  }
}

TEST(ExplorationGridTest, ReturnBeyondMaxRangeIsFreeSpaceNotAWall) {
  // A wall 7 m ahead: the sensor sees it, but returns beyond max_range are not trusted as walls.
  const LaserScan scan = CastScan({W(7.0, -20, 7.0, 20)}, Pose2{}, ExactNoReturnGeometry(),
                                  RayCastOptions{}, nullptr);
  ASSERT_TRUE(IsReturn(scan.ranges[90], scan.geometry));
  ExplorationGrid grid(kCell);
  grid.Integrate(Pose2{}, Pose2{}, scan, /*max_range=*/6.0, /*free_range=*/3.0, 0.3);
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(7.0, 0.0)), GridCell::kUnknown);
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(2.85, 0.0)), GridCell::kFree);
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(3.15, 0.0)), GridCell::kUnknown);
}

TEST(ExplorationGridTest, GrowsToCoverFarScansWithoutMovingEarlierCells) {
  ExplorationGrid grid(kCell);
  // An asymmetric pattern, so that a shift or a flip of the old cells shows.
  const std::vector<std::pair<Eigen::Vector2d, GridCell>> pattern = {
      {{0.05, 0.05}, GridCell::kOccupied}, {{0.15, 0.05}, GridCell::kFree},
      {{-0.25, 0.35}, GridCell::kOccupied}, {{0.05, 0.15}, GridCell::kUnknown}};
  for (const auto& [p, cell] : pattern) grid.Set(p, cell);
  auto expect_pattern = [&](const char* when) {
    for (const auto& [p, cell] : pattern) {
      const Eigen::Vector2i c = grid.CellOf(p);
      ASSERT_TRUE(grid.Inside(c.x(), c.y())) << when;
      EXPECT_EQ(grid.At(c.x(), c.y()), cell) << when << " at " << p.transpose();
      EXPECT_LT((grid.Centre(c) - p).norm(), 1e-9) << when << ": the lattice moved";
    }
  };
  expect_pattern("before growing");
  LaserScan scan;
  scan.geometry = ExactNoReturnGeometry();
  scan.ranges.assign(181, static_cast<float>(scan.geometry.no_return_range));
  // Far to the lower left, then far to the upper right: both sides grow.
  const Eigen::Vector2d origin = grid.origin();
  grid.Integrate(Pose2{-30.0, -25.0, M_PI}, Pose2{}, scan, 6.0, 3.0, 0.3);
  EXPECT_LT(grid.origin().x(), origin.x() - 20.0);
  EXPECT_LT(grid.origin().y(), origin.y() - 15.0);
  expect_pattern("after growing down");
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(-32.0, -25.0)), GridCell::kFree);
  grid.Integrate(Pose2{30.0, 25.0, 0.0}, Pose2{}, scan, 6.0, 3.0, 0.3);
  expect_pattern("after growing up");
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(-32.0, -25.0)), GridCell::kFree);
  EXPECT_EQ(CellAt(grid, Eigen::Vector2d(32.0, 25.0)), GridCell::kFree);
}

// ---------------------------------------------------------------------------------------------
// Frontiers on hand-made maps.

// A corridor: free [0, 6] x [0, 2], walls one cell thick along both sides (x in [-0.1, 6.1]) and
// at its left end; its right end is walled when `closed_end`.
ExplorationGrid Corridor(bool closed_end) {
  ExplorationGrid grid(kCell);
  Fill(&grid, -0.05, -0.05, 6.05, -0.05, GridCell::kOccupied);
  Fill(&grid, -0.05, 2.05, 6.05, 2.05, GridCell::kOccupied);
  Fill(&grid, -0.05, -0.05, -0.05, 2.05, GridCell::kOccupied);
  if (closed_end) Fill(&grid, 6.05, -0.05, 6.05, 2.05, GridCell::kOccupied);
  Fill(&grid, 0.05, 0.05, 5.95, 1.95, GridCell::kFree);
  return grid;
}

TEST(FrontierTest, ClosedRoomHasNoFrontierAndAClosedBoundary) {
  const ExplorationGrid grid = WalledRoom(4.0, 3.0);
  const Frontiers f = FindFrontiers(grid, /*min_cells=*/1);
  EXPECT_TRUE(f.regions.empty());
  EXPECT_EQ(f.open_cells, 0);
  // Every wall cell beside the interior closes it (the four corners touch it diagonally only).
  EXPECT_EQ(f.closed_cells, 2 * 40 + 2 * 30);
  EXPECT_EQ(f.OpenShare(), 0.0);
}

TEST(FrontierTest, SideOpeningIsOneFrontierRegionAtTheOpening) {
  ExplorationGrid grid = Corridor(/*closed_end=*/true);
  Fill(&grid, 2.4, 2.05, 3.6, 2.05, GridCell::kUnknown);  // 1.2 m of the left wall unseen
  const Frontiers f = FindFrontiers(grid, 5);
  ASSERT_EQ(f.regions.size(), 1u);
  const GridRegion& r = f.regions[0];
  for (int i : r.cells) {
    const Eigen::Vector2d c = grid.Centre(i % grid.width(), i / grid.width());
    EXPECT_TRUE(c.x() > 2.4 && c.x() < 3.6 && std::abs(c.y() - 1.95) < 1e-6) << c.transpose();
  }
  EXPECT_NEAR(r.centroid.x(), 3.0, 1e-6);
  EXPECT_NEAR(r.centroid.y(), 1.95, 1e-6);
  // The 12 unseen cells less the two beside the wall's ends (gaps in a wall, by the rule).
  EXPECT_NEAR(r.length, 1.0, 1e-9);
  EXPECT_GT(f.OpenShare(), 0.0);
  EXPECT_LT(f.OpenShare(), 0.1);
}

TEST(FrontierTest, GapsInAWallAreNotFrontiers) {
  // One unseen cell in a wall: beside occupied cells, so not open space (min_cells 1: no region
  // is dropped for its size, the rule alone decides).
  ExplorationGrid one = Corridor(true);
  one.Set({3.05, 2.05}, GridCell::kUnknown);
  const Frontiers f1 = FindFrontiers(one, 1);
  EXPECT_TRUE(f1.regions.empty());
  EXPECT_EQ(f1.open_cells, 0);
  // Three: the middle one touches no wall cell, and the free cell below it is a frontier.
  ExplorationGrid three = Corridor(true);
  Fill(&three, 2.95, 2.05, 3.15, 2.05, GridCell::kUnknown);
  const Frontiers f3 = FindFrontiers(three, 1);
  EXPECT_EQ(f3.open_cells, 1);
  ASSERT_EQ(f3.regions.size(), 1u);
  EXPECT_NEAR(f3.regions[0].centroid.x(), 3.05, 1e-6);
  EXPECT_TRUE(FindFrontiers(three, 5).regions.empty()) << "below min_cells";
}

TEST(FrontierTest, OpenCorridorEndIsAFrontier) {
  const ExplorationGrid grid = Corridor(/*closed_end=*/false);
  const Frontiers f = FindFrontiers(grid, 5);
  ASSERT_EQ(f.regions.size(), 1u);
  const GridRegion& r = f.regions[0];
  for (int i : r.cells) {
    EXPECT_NEAR(grid.Centre(i % grid.width(), i / grid.width()).x(), 5.95, 1e-6);
  }
  EXPECT_NEAR(r.centroid.y(), 1.0, 1e-6);
  // 20 cells across less the two whose unknown neighbour touches the side walls' ends.
  EXPECT_NEAR(r.length, 1.8, 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Grid paths on hand-made maps.

// Every cell of `path` keeps `distance` (Euclidean, to occupied cell centres) and is known free.
void ExpectClearAndFree(const ExplorationGrid& grid, const std::vector<Eigen::Vector2d>& path,
                        double distance) {
  for (const Eigen::Vector2d& p : path) {
    EXPECT_GE(DistanceToOccupied(grid, p), distance - 1e-6) << p.transpose();
    EXPECT_EQ(CellAt(grid, p), GridCell::kFree) << p.transpose();
  }
}

TEST(GridPathTest, GoesRoundAnObstacleKeepingTheRequiredDistance) {
  // An 8 x 5 m room; a box from y = 1.2 up to the top wall stands between start and goal, so the
  // way round is below it.
  ExplorationGrid grid = WalledRoom(8.0, 5.0);
  Fill(&grid, 3.5, 1.2, 4.5, 4.95, GridCell::kOccupied);
  PathOptions options;
  options.required_distance = 0.4;
  options.wall_penalty = 0.0;  // the shortest path, so its length can be bounded
  const Eigen::Vector2d from(1.05, 2.55), to(7.05, 2.55);
  const std::vector<Eigen::Vector2d> path = PlanPath(grid, from, to, options);
  ASSERT_FALSE(path.empty());
  EXPECT_LT((path.back() - to).norm(), 1e-9);
  ExpectClearAndFree(grid, path, options.required_distance);
  const double lowest = std::min_element(path.begin(), path.end(), [](const auto& a,
                                                                       const auto& b) {
                          return a.y() < b.y();
                        })->y();
  EXPECT_LT(lowest, 1.2) << "went below the box";
  // Longer than the straight line; shorter than a collision-free polyline round the box (start,
  // (3.05, 0.65), (4.95, 0.65), goal: 0.6 m or more from every occupied cell) stretched by the
  // worst ratio of an 8-connected path to a straight one (1 / cos 22.5 deg), plus a diagonal
  // step at either end for the cell rounding.
  const double polyline = 2 * std::hypot(2.0, 1.9) + 1.9;
  const double length = PathLength(path);
  EXPECT_GT(length, (to - from).norm() + 0.5);
  EXPECT_LT(length, polyline / std::cos(M_PI / 8) + 2 * M_SQRT2 * kCell);
}

// Two 5 x 5 m rooms side by side; the wall between them (x in [5.0, 5.1]) has a doorway of
// `width` centred at y = 2.5.
ExplorationGrid TwoRoomsGrid(double width) {
  ExplorationGrid grid = WalledRoom(10.1, 5.0);
  Fill(&grid, 5.05, 0.05, 5.05, 4.95, GridCell::kOccupied);
  Fill(&grid, 5.05, 2.5 - width / 2, 5.05, 2.5 + width / 2, GridCell::kFree);
  return grid;
}

TEST(GridPathTest, PassesThroughADoorwayOnlyWhenTheRobotFits) {
  PathOptions options;
  options.required_distance = 0.4;
  const Eigen::Vector2d from(2.55, 2.55), to(7.55, 2.55);
  const ExplorationGrid wide = TwoRoomsGrid(1.2);
  const std::vector<Eigen::Vector2d> path = PlanPath(wide, from, to, options);
  ASSERT_FALSE(path.empty());
  ExpectClearAndFree(wide, path, options.required_distance);
  const bool through_doorway = std::any_of(path.begin(), path.end(), [](const auto& p) {
    return std::abs(p.x() - 5.05) < 1e-6 && p.y() > 1.9 && p.y() < 3.1;
  });
  EXPECT_TRUE(through_doorway);
  // 0.6 m is narrower than the robot's 0.8 m disc; a 0.5 m disc passes it.
  const ExplorationGrid narrow = TwoRoomsGrid(0.6);
  EXPECT_TRUE(PlanPath(narrow, from, to, options).empty());
  options.required_distance = 0.25;
  EXPECT_FALSE(PlanPath(narrow, from, to, options).empty());
}

TEST(GridPathTest, NeverEntersUnknownCells) {
  // A 6 x 4 m room with an unseen 2 x 2 m block in its middle (unknown, not walled: it does not
  // push paths away the way a wall does).
  ExplorationGrid grid = WalledRoom(6.0, 4.0);
  const Eigen::Vector2d from(1.05, 2.05), to(5.05, 2.05);
  PathOptions options;
  options.required_distance = 0.4;
  const double straight = PathLength(PlanPath(grid, from, to, options));
  EXPECT_NEAR(straight, 4.0, 1e-6) << "with the block seen, straight across";
  Fill(&grid, 2.0, 1.0, 4.0, 3.0, GridCell::kUnknown);
  const std::vector<Eigen::Vector2d> path = PlanPath(grid, from, to, options);
  ASSERT_FALSE(path.empty());
  ExpectClearAndFree(grid, path, options.required_distance);
  // Cell centres outside the block, joined by steps that cut no corner, go round it: at least
  // start -> a corner -> the next corner -> goal.
  EXPECT_GT(PathLength(path), 2 * std::hypot(0.95, 1.05) + 2.0);
  EXPECT_TRUE(PlanPath(grid, from, Eigen::Vector2d(3.05, 2.05), options).empty())
      << "a goal in unknown space is not reached";
}

// A robot standing 0.3 m from a wall (closer than the 0.45 m paths keep) may leave along cells
// no closer to the wall than its own, within the escape radius, and no other way.
TEST(GridPathTest, EscapeLetsARobotNearAWallLeaveWithoutGettingCloser) {
  const ExplorationGrid grid = WalledRoom(4.0, 3.0);
  PathOptions options;
  options.required_distance = 0.45;
  const Eigen::Vector2d start(2.05, 0.25);  // 0.3 m from the bottom wall's cells
  ASSERT_NEAR(DistanceToOccupied(grid, start), 0.3, 1e-9);
  const std::vector<Eigen::Vector2d> out = PlanPath(grid, start, {2.05, 1.55}, options);
  ASSERT_FALSE(out.empty());
  for (const Eigen::Vector2d& p : out) {
    EXPECT_GE(DistanceToOccupied(grid, p), 0.3 - 1e-6) << p.transpose();
  }
  EXPECT_FALSE(PlanPath(grid, start, {2.35, 0.25}, options).empty()) << "along the wall";
  EXPECT_TRUE(PlanPath(grid, start, {2.35, 0.15}, options).empty()) << "closer to the wall";
  // Without the escape region round the start, the robot could not leave at all.
  const std::vector<float> distance = ObstacleDistance(grid, 2.0f);
  PathOptions no_escape = options;
  no_escape.escape_centre = Eigen::Vector2d(-10.0, -10.0);
  const CostField field(grid, distance, start, no_escape);
  EXPECT_FALSE(field.Reachable(field.CellIndex({2.05, 1.55})));
}

}  // namespace
}  // namespace waymark::laser_slam

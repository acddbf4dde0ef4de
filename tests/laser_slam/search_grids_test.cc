// The search's speed-ups must not change what it finds (issue 33, "100x real time"): the pyramid
// built row by row against its definition, a grid drawn on a larger cloud's lattice against the
// whole cloud's grid, FindRivals against the two FindRival searches it replaces, the submap
// pyramid cache's memory budget, and thinning against its definition.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/loop_search.h"
#include "server/laser_slam/mapping/point_cloud.h"

namespace waymark::laser_slam {
namespace {

PointCloud RandomWalls(int count, float span, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> at(0.0f, span);
  PointCloud points;
  for (int w = 0; w < count; ++w) {
    const Eigen::Vector2f a(at(rng), at(rng)), b(at(rng), at(rng));
    for (float t = 0.0f; t <= 1.0f; t += 0.01f) points.push_back(a + t * (b - a));
  }
  return points;
}

TEST(SearchPyramidTest, EveryLevelIsTheMaximumOverItsSquare) {
  for (int x0 : {0, 7}) {
    LikelihoodGrid grid = BuildLikelihoodGrid(RandomWalls(6, 3.0f, 1), 0.05, 0.05);
    grid.x0 = x0;  // a window of a larger lattice
    grid.y0 = 2 * x0;
    const SearchPyramid pyramid(grid, 4);
    for (int d = 0; d <= 4; ++d) {
      const int size = 1 << d;
      for (int y = grid.y0 - 20; y < grid.y0 + grid.height + 5; y += 3) {
        for (int x = grid.x0 - 20; x < grid.x0 + grid.width + 5; x += 3) {
          std::uint8_t expected = 0;
          for (int dy = 0; dy < size; ++dy) {
            for (int dx = 0; dx < size; ++dx) expected = std::max(expected, grid.At(x + dx, y + dy));
          }
          ASSERT_EQ(pyramid.At(d, x, y), expected) << "level " << d << " at " << x << ", " << y;
        }
      }
    }
  }
}

TEST(LikelihoodGridTest, APartDrawnOnTheWholeCloudsLatticeHasItsCells) {
  const PointCloud all = RandomWalls(8, 6.0f, 2);
  const LikelihoodGrid whole = BuildLikelihoodGrid(all, 0.05, 0.05);
  const GridFrame frame = GridFrameOf(all, 0.05, 0.05);
  // All of it on its own lattice: the same grid, cell for cell.
  const LikelihoodGrid same = BuildLikelihoodGrid(all, 0.05, 0.05, frame);
  for (int y = -2; y < whole.height + 2; ++y) {
    for (int x = -2; x < whole.width + 2; ++x) ASSERT_EQ(same.At(x, y), whole.At(x, y));
  }
  // A part: smaller, and the same cells where no left-out point reaches.
  PointCloud part;
  for (const Eigen::Vector2f& p : all) {
    if (p.x() < 3.0f) part.push_back(p);
  }
  const LikelihoodGrid cut = BuildLikelihoodGrid(part, 0.05, 0.05, frame);
  const LikelihoodGrid alone = BuildLikelihoodGrid(part, 0.05, 0.05);
  EXPECT_LT(static_cast<size_t>(cut.width) * cut.height, whole.cells.size());
  EXPECT_EQ(cut.origin, whole.origin);
  // Away from the left-out points (a kernel and a cell): the whole cloud's cells and values; a
  // grid of the part alone has its own lattice, and other values between the cells.
  bool phase_differs = false;
  for (const Eigen::Vector2f& p : part) {
    if (p.x() > 2.7f) continue;
    EXPECT_EQ(cut.Interpolate(p.x(), p.y()), whole.Interpolate(p.x(), p.y()));
    phase_differs = phase_differs || alone.Interpolate(p.x(), p.y()) != whole.Interpolate(p.x(), p.y());
  }
  EXPECT_TRUE(phase_differs);
  // Too large for the budget: an empty grid, nothing allocated.
  EXPECT_TRUE(BuildLikelihoodGrid(part, 0.05, 0.05, frame, 100).empty());
}

TEST(FindRivalsTest, AnswersWhatTheTwoFindRivalSearchesAnswer) {
  // A scene with repeated structure: the same walls twice, 4 m apart.
  const PointCloud walls = RandomWalls(5, 3.0f, 3);
  PointCloud map = walls;
  for (const Eigen::Vector2f& p : walls) map.push_back(p + Eigen::Vector2f(4.0f, 0.3f));
  const SearchPyramid pyramid(BuildLikelihoodGrid(ThinPoints(map, 0.05), 0.05, 0.05), 6);
  const PointCloud scan = ThinPoints(TransformPoints(walls, Pose2{-0.5, -0.5, 0.0}), 0.05);
  // A window over both copies, and one over the scan's own place only.
  for (const auto& [initial, window] : {std::make_pair(Pose2{2.5, 0.6, 0.0}, SearchWindow{5.0, 0.2}),
                                        std::make_pair(Pose2{0.7, 0.6, 0.0}, SearchWindow{0.8, 0.1})}) {
    const std::optional<GridMatch> match = MatchInWindow(pyramid, scan, initial, window, 0.4);
    ASSERT_TRUE(match.has_value());
    for (double ratio : {0.9, 0.5}) {
      const double min_score = ratio * match->lattice_score;
      const Rivals rivals =
          FindRivals(pyramid, scan, initial, window, match->pose, 0.3, 1.0, min_score);
      const std::optional<GridMatch> far =
          FindRival(pyramid, scan, initial, window, match->pose, 1.0, min_score);
      ASSERT_EQ(rivals.far.has_value(), far.has_value());
      if (far) {
        EXPECT_EQ(rivals.far->x, far->pose.x);
        EXPECT_EQ(rivals.far->theta, far->pose.theta);
        continue;
      }
      const std::optional<GridMatch> near =
          FindRival(pyramid, scan, initial, window, match->pose, 0.3, min_score);
      ASSERT_EQ(rivals.near.has_value(), near.has_value());
      if (near) {
        EXPECT_EQ(rivals.near->x, near->pose.x);
        EXPECT_EQ(rivals.near->y, near->pose.y);
      }
    }
  }
}

TEST(PyramidCacheTest, KeepsTheRecentlyUsedWithinItsBudget) {
  const auto pyramid = [](float span) {
    return std::make_shared<const SearchPyramid>(
        BuildLikelihoodGrid(RandomWalls(3, span, 4), 0.05, 0.05), 3);
  };
  const auto a = pyramid(2.0f);
  PyramidCache cache(3 * a->bytes());
  cache.Insert(0, 1, a);
  cache.Insert(1, 1, pyramid(2.0f));
  cache.Insert(2, 1, pyramid(2.0f));
  EXPECT_NE(cache.Find(0, 1), nullptr);  // now the most recently used
  cache.Insert(3, 1, pyramid(2.0f));      // over the budget: submap 1 goes
  EXPECT_NE(cache.Find(0, 1), nullptr);
  EXPECT_EQ(cache.Find(1, 1), nullptr);
  EXPECT_LE(cache.bytes(), 3 * a->bytes() + a->bytes());
  EXPECT_EQ(cache.Find(0, 2), nullptr);  // another coarsening is another grid
  cache.SetFrame(1, GridFrame{Eigen::Vector2d(1.0, 2.0), 10, 20});
  ASSERT_TRUE(cache.Frame(1).has_value());  // frames stay
  EXPECT_EQ(cache.Frame(1)->height, 20);
  EXPECT_FALSE(cache.Frame(5).has_value());
}

// One point per cell, the first in the input's order, every other dropped: ThinPoints' own set of
// cells against a std::set, on walls around the origin (negative cells, and the cell (-1, -1)
// whose key has every bit set).
TEST(ThinPointsTest, KeepsTheFirstPointOfEveryCellInOrder) {
  for (unsigned seed : {1u, 2u, 3u}) {
    PointCloud points = RandomWalls(40, 12.0f, seed);
    for (Eigen::Vector2f& p : points) p -= Eigen::Vector2f(6.0f, 6.0f);
    points.emplace_back(-0.01f, -0.02f);
    points.emplace_back(-0.03f, -0.04f);  // the same cell (-1, -1) at 5 cm
    for (double cell : {0.05, 0.1, 0.4}) {
      std::set<std::pair<long, long>> seen;
      PointCloud expected;
      for (const Eigen::Vector2f& p : points) {
        const std::pair<long, long> key(static_cast<long>(std::floor(p.x() / cell)),
                                        static_cast<long>(std::floor(p.y() / cell)));
        if (seen.insert(key).second) expected.push_back(p);
      }
      const PointCloud thinned = ThinPoints(points, cell);
      ASSERT_EQ(thinned.size(), expected.size()) << "seed " << seed << ", cell " << cell;
      EXPECT_TRUE(std::equal(thinned.begin(), thinned.end(), expected.begin()));
      EXPECT_LT(thinned.size(), points.size());
    }
  }
}

}  // namespace
}  // namespace waymark::laser_slam

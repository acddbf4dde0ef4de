// Localization that knows when it is unsure (issue 33): no first fix between two identical rooms,
// a fix where the place is unique, every fix with its rival, and the global search spread over
// scans under its budget (inline and on the localizer's thread). Synthetic rooms with known
// answers; the real logs are measured with waymark-laser-eval --localize.

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/localizer.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::Wall;

PointCloud PointsFrom(const std::vector<Wall>& walls, const Pose2& pose) {
  return testing::ScanPoints(walls, pose);
}

// Two closed rooms 12 m apart, 8 m x 6 m with a pillar at the same place in each: from inside
// one, nothing tells which. `partition`: the east room also has a 3 m wall across its middle.
std::vector<Wall> TwinRooms(bool partition) {
  std::vector<Wall> walls;
  for (double x0 : {0.0, 12.0}) {
    for (const Wall& w : Box(x0, 0.0, x0 + 8.0, 6.0)) walls.push_back(w);
    for (const Wall& w : Box(x0 + 5.0, 1.0, x0 + 5.6, 1.8)) walls.push_back(w);
  }
  if (partition) walls.push_back({{14.0, 4.0}, {17.0, 4.0}});
  return walls;
}

// The map as a mapping session keeps it: scans from a few places in each room.
PointCloud MapOf(const std::vector<Wall>& walls) {
  PointCloud map;
  for (double x0 : {0.0, 12.0}) {
    for (const Pose2& p : {Pose2{x0 + 2.0, 2.0, 0.0}, Pose2{x0 + 6.5, 4.5, M_PI},
                           Pose2{x0 + 1.5, 5.0, -M_PI / 2}, Pose2{x0 + 7.0, 0.5, M_PI / 2}}) {
      AppendTransformed(PointsFrom(walls, p), p, &map);
    }
  }
  return map;
}

// The robot drives a circle of 1 m radius around `centre` (0.1 rad per scan), starting from an
// unknown pose; the EKF's local frame is its start. Returns every answer.
struct Drive {
  std::vector<LocalizationResult> results;
  std::vector<Pose2> truths;
  std::vector<Pose2> locals;
};

Drive DriveCircle(MapLocalizer& localizer, const std::vector<Wall>& walls, const Pose2& centre,
                  int scans) {
  Drive drive;
  Pose2 start;
  for (int i = 0; i < scans; ++i) {
    const double a = 0.1 * i;
    const Pose2 truth{centre.x + std::cos(a), centre.y + std::sin(a), a + M_PI / 2};
    if (i == 0) start = truth;
    const Pose2 local = Relative(start, truth);
    drive.results.push_back(localizer.AddScan(i + 1, i, local, PointsFrom(walls, truth)));
    drive.truths.push_back(truth);
    drive.locals.push_back(local);
  }
  return drive;
}

TEST(LocalizationAmbiguityTest, TwoIdenticalRoomsGetNoFirstFix) {
  const std::vector<Wall> walls = TwinRooms(false);
  absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer =
      MapLocalizer::Create(LocalizationOptions{}, MapOf(walls));
  ASSERT_TRUE(localizer.ok()) << localizer.status();
  const Drive drive = DriveCircle(**localizer, walls, Pose2{16.0, 3.0, 0.0}, 120);
  int ambiguous = 0;
  for (const LocalizationResult& r : drive.results) {
    EXPECT_FALSE(r.localized);
    EXPECT_EQ(r.fixes, 0);
    EXPECT_NE(r.state, LocalizationState::kTracking);
    if (r.state != LocalizationState::kAmbiguous) continue;
    ++ambiguous;
    // The match's twin, 12 m along x, fits as well.
    EXPECT_GE(r.rival_ratio, 0.9);
    EXPECT_NEAR(r.rival_distance, 12.0, 0.3);
    EXPECT_LT(r.rival_angle, 0.1);
    EXPECT_GT(r.score, 0.65);  // a good match: refused for its rival, not for its score
  }
  // Many searches were answered over the drive, and every one was refused.
  EXPECT_GE(ambiguous, 10);
}

TEST(LocalizationAmbiguityTest, AUniqueRoomGetsAFixAndItsTwinWithoutTheWallDoesNot) {
  const std::vector<Wall> walls = TwinRooms(true);
  const PointCloud map = MapOf(walls);
  {
    // In the east room, the partition tells the rooms apart.
    absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer =
        MapLocalizer::Create(LocalizationOptions{}, map);
    ASSERT_TRUE(localizer.ok());
    const Drive drive = DriveCircle(**localizer, walls, Pose2{15.5, 2.3, 0.0}, 120);
    const LocalizationResult& last = drive.results.back();
    ASSERT_TRUE(last.localized);
    EXPECT_EQ(last.state, LocalizationState::kTracking);
    size_t first_fix = 0;
    while (!drive.results[first_fix].localized) ++first_fix;
    // The fix is the one that counts: its confidence says it is unique.
    const LocalizationResult& fix = drive.results[first_fix];
    EXPECT_GE(fix.score, 0.65);
    EXPECT_LT(fix.rival_ratio, 0.9);
    for (size_t i = first_fix; i < drive.results.size(); ++i) {
      const Pose2 found = (*localizer)->ToMap(i + 1, drive.locals[i]);
      EXPECT_NEAR(found.x, drive.truths[i].x, 0.1) << i;
      EXPECT_NEAR(found.y, drive.truths[i].y, 0.1) << i;
    }
  }
  {
    // In the west room: everything it sees is also in the east room (which only adds a wall).
    absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer =
        MapLocalizer::Create(LocalizationOptions{}, map);
    ASSERT_TRUE(localizer.ok());
    const Drive drive = DriveCircle(**localizer, walls, Pose2{3.5, 2.3, 0.0}, 120);
    bool refused = false;
    for (const LocalizationResult& r : drive.results) {
      EXPECT_FALSE(r.localized);
      refused = refused || r.state == LocalizationState::kAmbiguous;
    }
    EXPECT_TRUE(refused);
  }
}

// The whole search's cost, spread: with a budget a tenth of it per scan, no single scan finishes
// it, and the fix is as right as the one unbounded searches give.
TEST(LocalizationBudgetTest, TheGlobalSearchIsSpreadOverScansAndFindsTheRobot) {
  const std::vector<Wall> walls = TwinRooms(true);
  const PointCloud map = MapOf(walls);
  struct FirstFix {
    size_t scan = 0;    // index of the first answer localized (scans driven: none)
    double error = 0.0;  // of its pose in the map, against the truth (m)
  };
  constexpr int kScans = 200;
  const auto first_fix = [&](const LocalizationOptions& options) {
    absl::StatusOr<std::unique_ptr<MapLocalizer>> localizer = MapLocalizer::Create(options, map);
    EXPECT_TRUE(localizer.ok());
    const Drive drive = DriveCircle(**localizer, walls, Pose2{15.5, 2.3, 0.0}, kScans);
    FirstFix fix{drive.results.size(), 0.0};
    for (size_t i = 0; i < drive.results.size(); ++i) {
      if (!drive.results[i].localized) continue;
      const Pose2 found = (*localizer)->ToMap(i + 1, drive.locals[i]);
      fix = {i, std::hypot(found.x - drive.truths[i].x, found.y - drive.truths[i].y)};
      break;
    }
    return fix;
  };
  LocalizationOptions unbounded;
  unbounded.global_reads_per_scan = std::int64_t{1} << 50;
  const FirstFix whole = first_fix(unbounded);
  ASSERT_LT(whole.scan, kScans);
  EXPECT_LT(whole.error, 0.1);

  // The first search's cost (its query is the first scan alone), measured.
  LocalizationOptions options;
  {
    const double res = options.global_coarsening * options.grid_resolution;
    const double sigma = options.global_coarsening * options.grid_sigma;
    const SearchPyramid coarse(BuildLikelihoodGrid(ThinPoints(map, res), res, sigma),
                               options.global_depth);
    const SearchPyramid fine(BuildLikelihoodGrid(ThinPoints(map, 0.05), 0.05, 0.05), 6);
    GlobalSearchSettings settings;
    settings.query_cell = options.global_query_cell;
    GlobalSearch search(coarse, fine, settings, 1, 0.0, Pose2{},
                        ThinPoints(PointsFrom(walls, Pose2{16.5, 2.3, M_PI / 2}), 0.05));
    ASSERT_TRUE(search.Resume(std::int64_t{1} << 50));
    options.global_reads_per_scan = search.outcome().reads / 10;
  }
  const FirstFix spread = first_fix(options);
  ASSERT_LT(spread.scan, kScans);
  EXPECT_GE(spread.scan, whole.scan + 10);
  EXPECT_LT(spread.error, 0.1);

  // On the localizer's thread: scans faster than it waits for it only when it is two budgets
  // behind, so the fix comes within a few scans of the inline one.
  options.threads = 1;
  const FirstFix threaded = first_fix(options);
  ASSERT_LT(threaded.scan, kScans);
  EXPECT_LT(threaded.error, 0.1);
  EXPECT_LE(threaded.scan, spread.scan + 10);
}

// The resumable branch and bound answers what the whole one does, however it is cut.
TEST(LocalizationBudgetTest, AResumedSearchAnswersWhatAWholeOneDoes) {
  const std::vector<Wall> walls = TwinRooms(true);
  const SearchPyramid pyramid(BuildLikelihoodGrid(ThinPoints(MapOf(walls), 0.05), 0.05, 0.05), 6);
  const PointCloud scan = PointsFrom(walls, Pose2{14.5, 2.5, 0.1});
  const SearchWindow window{10.0, 0.5};
  const Pose2 initial{10.0, 3.0, 0.0};
  const std::optional<GridMatch> whole = MatchInWindow(pyramid, scan, initial, window, 0.5);
  ASSERT_TRUE(whole.has_value());
  BranchAndBoundSearch search(pyramid, scan, initial, window, 0.5);
  int resumes = 0;
  while (!search.Resume(20000)) ++resumes;
  EXPECT_GT(resumes, 10);
  const std::optional<GridMatch> cut = search.result();
  ASSERT_TRUE(cut.has_value());
  EXPECT_EQ(cut->candidates, whole->candidates);
  EXPECT_EQ(cut->lattice_score, whole->lattice_score);
  EXPECT_NEAR(cut->pose.x, 14.5, 0.05);
}

}  // namespace
}  // namespace waymark::laser_slam

#include "server/visual_slam/geometry/essential_solver.h"

#include <gtest/gtest.h>

#include <limits>
#include <numeric>
#include <vector>

#include "server/visual_slam/geometry/two_view.h"
#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::AllIndices;
using testing::kFocal;
using testing::MakeMotion;
using testing::Scene;
using testing::SceneMaker;

const Motion kTruth = MakeMotion(3, -2, 1, Eigen::Vector3d(0.25, -0.05, 0.12));

TEST(EssentialSolver, MinimalSampleWithoutNoiseGivesTheMotion) {
  SceneMaker maker(1);
  const Scene s = maker.Make(20, 0.0, 0.0, kTruth);
  EssentialSolver solver(s.c, kFocal);
  EXPECT_EQ(solver.SampleSize(), 5);
  EXPECT_TRUE(solver.UnitTranslation());
  const std::vector<Motion> motions = solver.Solve({0, 1, 2, 3, 4, 5, 6, 7});
  ASSERT_EQ(motions.size(), 1u);
  EXPECT_LT(testing::RotationErrorDeg(motions[0].R, kTruth.R), 1e-6);
  EXPECT_LT(testing::DirectionErrorDeg(motions[0].t, kTruth.t), 1e-6);
  EXPECT_NEAR(motions[0].t.norm(), 1.0, 1e-12);
  // The pairs not in the sample fit it too.
  for (int i = 8; i < 20; ++i) EXPECT_LT(solver.ErrorPx(motions[0], i), 1e-6);
}

TEST(EssentialSolver, ErrorIsSampsonDistanceInPixels) {
  // Pure sideways motion: epipolar lines are horizontal, so moving the current point up by k px
  // puts it k px off its line; the Sampson distance splits that between the two images
  // (k / sqrt(2) when both are equally sensitive, as here with x_r = x_c on the axis).
  Motion sideways;
  sideways.t = Eigen::Vector3d(1, 0, 0);
  std::vector<Correspondence> c(2);
  c[0].reference = Eigen::Vector2d(0, 0);
  c[0].current = Eigen::Vector2d(-0.1, 0);
  c[1].reference = Eigen::Vector2d(0, 0);
  c[1].current = Eigen::Vector2d(-0.1, 4 / kFocal);
  EssentialSolver solver(c, kFocal);
  EXPECT_NEAR(solver.ErrorPx(sideways, 0), 0, 1e-12);
  EXPECT_NEAR(solver.ErrorPx(sideways, 1), 4 / std::sqrt(2.0), 1e-9);
  EXPECT_EQ(solver.ErrorPx(sideways, 2), std::numeric_limits<double>::infinity());
  EXPECT_EQ(solver.ErrorPx(sideways, -1), std::numeric_limits<double>::infinity());
}

TEST(EssentialFromInliers, NoisyInliersGiveTheMotion) {
  SceneMaker maker(2);
  const Scene s = maker.Make(150, 0.0, 0.5, kTruth);
  const absl::StatusOr<Motion> m = EssentialFromInliers(s.c, AllIndices(150));
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, kTruth.R), 0.3);
  EXPECT_LT(testing::DirectionErrorDeg(m->t, kTruth.t), 1.0);
  EXPECT_NEAR(m->t.norm(), 1.0, 1e-9);
}

TEST(EssentialFromInliers, EveryOtherMotionDirection) {
  // Forward, backward, up and sideways-left motions: the cheirality vote picks the right one of
  // the four decompositions (t and -t, R and its twisted pair).
  const Eigen::Vector3d directions[] = {{0, 0, 0.3}, {0, 0, -0.3}, {0, -0.3, 0}, {-0.3, 0, 0.05}};
  for (const Eigen::Vector3d& t : directions) {
    const Motion truth = MakeMotion(1, 2, -1, t);
    SceneMaker maker(3);
    const Scene s = maker.Make(60, 0.0, 0.0, truth);
    const absl::StatusOr<Motion> m = EssentialFromInliers(s.c, AllIndices(60));
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_LT(testing::RotationErrorDeg(m->R, truth.R), 1e-4) << t.transpose();
    EXPECT_LT(testing::DirectionErrorDeg(m->t, truth.t), 1e-4) << t.transpose();
  }
}

TEST(EssentialFromInliers, TooFewOrBadIndicesAreInvalidArgument) {
  SceneMaker maker(4);
  const Scene s = maker.Make(20, 0.0, 0.0, kTruth);
  EXPECT_EQ(EssentialFromInliers(s.c, {0, 1, 2, 3, 4, 5, 6}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EssentialFromInliers(s.c, {0, 1, 2, 3, 4, 5, 6, 20}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EssentialFromInliers({}, {}).status().code(), absl::StatusCode::kInvalidArgument);
  EssentialSolver solver(s.c, kFocal);
  EXPECT_TRUE(solver.Solve({0, 1, 2}).empty());
  EXPECT_TRUE(solver.Solve({0, 1, 2, 3, 4, 5, 6, 99}).empty());
}

TEST(EssentialFromInliers, DegenerateGeometryIsAnError) {
  // No translation: any t fits, the constraint has a three-dimensional null space.
  const Motion rotation = MakeMotion(2, 3, 1, Eigen::Vector3d::Zero());
  SceneMaker maker(5);
  const Scene still = maker.Make(40, 0.0, 0.0, rotation);
  EXPECT_EQ(EssentialFromInliers(still.c, AllIndices(40)).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EssentialSolver still_solver(still.c, kFocal);
  EXPECT_TRUE(still_solver.Solve({0, 1, 2, 3, 4, 5, 6, 7}).empty());

  // All points on one 3-D line: their images are collinear.
  std::vector<Correspondence> line;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d X(-1 + 0.1 * i, 0.2 + 0.02 * i, 3 + 0.1 * i);
    line.push_back(maker.Pair(X, kTruth, 0.0));
  }
  EXPECT_FALSE(EssentialFromInliers(line, AllIndices(20)).ok());
  EssentialSolver line_solver(line, kFocal);
  EXPECT_TRUE(line_solver.Solve({0, 2, 4, 6, 8, 10, 12, 14}).empty());

  // The same pair eight times.
  std::vector<Correspondence> same(8, maker.Pair(Eigen::Vector3d(0, 0, 3), kTruth, 0.0));
  EXPECT_FALSE(EssentialFromInliers(same, AllIndices(8)).ok());

  // Non-finite coordinates.
  Scene bad = maker.Make(10, 0.0, 0.0, kTruth);
  bad.c[3].current.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(EssentialFromInliers(bad.c, AllIndices(10)).ok());
}

TEST(DecomposeEssential, CountsPairsInFront) {
  SceneMaker maker(6);
  const Scene s = maker.Make(30, 0.0, 0.0, kTruth);
  Motion unit = kTruth;
  unit.t.normalize();
  const std::optional<Decomposition> d = DecomposeEssential(EssentialOf(unit), s.c, AllIndices(30));
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->in_front, 30);
  EXPECT_LT(testing::DirectionErrorDeg(d->motion.t, kTruth.t), 1e-6);
}

}  // namespace
}  // namespace waymark::visual_slam

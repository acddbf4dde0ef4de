#include "server/visual_slam/geometry/pnp_solver.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::AllIndices;
using testing::kFocal;
using testing::MakeMotion;
using testing::Scene;
using testing::SceneMaker;

constexpr double kInf = std::numeric_limits<double>::infinity();

const Motion kTruth = MakeMotion(-2, 4, 1, Eigen::Vector3d(0.15, -0.05, 0.2));

TEST(PnpSolver, P3PSolutionsContainTheTruth) {
  SceneMaker maker(1);
  const Scene s = maker.Make(10, 0.0, 0.0, kTruth);
  PnpSolver solver(s.c, kFocal);
  EXPECT_EQ(solver.SampleSize(), 3);
  EXPECT_FALSE(solver.UnitTranslation());
  const std::vector<Motion> motions = solver.Solve({0, 1, 2});
  ASSERT_FALSE(motions.empty());
  EXPECT_LE(motions.size(), 4u);
  double best = kInf;
  for (const Motion& m : motions) {
    best = std::min(best, testing::RotationErrorDeg(m.R, kTruth.R) + (m.t - kTruth.t).norm());
  }
  EXPECT_LT(best, 1e-6);
}

TEST(PnpSolver, ErrorIsReprojectionDistanceInPixels) {
  std::vector<Correspondence> c(4);
  c[0].reference_point = Eigen::Vector3d(0, 0, 2);
  c[0].current = Eigen::Vector2d(0, 0);
  c[1].reference_point = Eigen::Vector3d(0.2, 0, 2);
  c[1].current = Eigen::Vector2d(0.1 + 3 / kFocal, 4 / kFocal);  // 5 px off
  c[2].reference_point = Eigen::Vector3d(0, 0, 2);               // behind after the motion
  c[3].current = Eigen::Vector2d(0, 0);                          // no depth
  PnpSolver solver(c, kFocal);
  const Motion identity;
  EXPECT_NEAR(solver.ErrorPx(identity, 0), 0, 1e-12);
  EXPECT_NEAR(solver.ErrorPx(identity, 1), 5, 1e-9);
  Motion back;
  back.t = Eigen::Vector3d(0, 0, -3);
  EXPECT_EQ(solver.ErrorPx(back, 2), kInf);
  EXPECT_EQ(solver.ErrorPx(identity, 3), kInf);
  EXPECT_EQ(solver.ErrorPx(identity, 4), kInf);
  EXPECT_TRUE(solver.Samplable(0));
  EXPECT_FALSE(solver.Samplable(3));
  EXPECT_FALSE(solver.Samplable(-1));
  EXPECT_FALSE(solver.Samplable(4));
}

TEST(PnpSolver, DegenerateSamplesGiveNoMotionAndNoCrash) {
  SceneMaker maker(2);
  Scene s = maker.Make(10, 0.0, 0.0, kTruth);
  PnpSolver solver(s.c, kFocal);
  EXPECT_TRUE(solver.Solve({0, 1}).empty());
  EXPECT_TRUE(solver.Solve({0, 1, 2, 3}).empty());
  EXPECT_TRUE(solver.Solve({0, 1, 42}).empty());
  // Three collinear points.
  std::vector<Correspondence> line;
  for (int i = 0; i < 3; ++i) line.push_back(maker.Pair(Eigen::Vector3d(0.1 * i, 0, 3), kTruth, 0));
  PnpSolver line_solver(line, kFocal);
  for (const Motion& m : line_solver.Solve({0, 1, 2})) {
    EXPECT_TRUE(m.R.allFinite());
    EXPECT_TRUE(m.t.allFinite());
  }
  // The same point three times.
  std::vector<Correspondence> same(3, maker.Pair(Eigen::Vector3d(0.1, 0.1, 3), kTruth, 0));
  PnpSolver same_solver(same, kFocal);
  for (const Motion& m : same_solver.Solve({0, 1, 2})) EXPECT_TRUE(m.R.allFinite());
  // No depth.
  s.c[0].reference_point.reset();
  EXPECT_TRUE(PnpSolver(s.c, kFocal).Solve({0, 1, 2}).empty());
}

TEST(RefinePnp, ImprovesAPerturbedStartToTheTruth) {
  SceneMaker maker(3);
  const Scene exact = maker.Make(80, 0.0, 0.0, kTruth);
  Motion start = kTruth;
  start.R = MakeMotion(1.5, -1, 2, Eigen::Vector3d::Zero()).R * start.R;  // ~2.7 deg off
  start.t += Eigen::Vector3d(0.05, -0.04, 0.06);                          // ~9 cm off
  absl::StatusOr<Motion> m = RefinePnp(exact.c, AllIndices(80), start, kFocal);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, kTruth.R), 1e-5);
  EXPECT_LT((m->t - kTruth.t).norm(), 1e-6);

  const Scene noisy = maker.Make(150, 0.0, 0.5, kTruth);
  m = RefinePnp(noisy.c, AllIndices(150), start, kFocal);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, kTruth.R), 0.1);
  EXPECT_LT((m->t - kTruth.t).norm(), 0.005);
  EXPECT_NEAR((m->R.transpose() * m->R - Eigen::Matrix3d::Identity()).norm(), 0, 1e-9);
}

TEST(RefinePnp, HuberWeightResistsAFewOutliers) {
  SceneMaker maker(4);
  Scene s = maker.Make(100, 0.0, 0.5, kTruth);
  for (int i = 0; i < 5; ++i) s.c[i].current += Eigen::Vector2d(20, -15) / kFocal;  // 25 px off
  const absl::StatusOr<Motion> m = RefinePnp(s.c, AllIndices(100), kTruth, kFocal);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, kTruth.R), 0.15);
  EXPECT_LT((m->t - kTruth.t).norm(), 0.01);
}

TEST(RefinePnp, RejectsTooFewPointsAndBadInput) {
  SceneMaker maker(5);
  Scene s = maker.Make(10, 0.0, 0.0, kTruth);
  EXPECT_EQ(RefinePnp(s.c, {0, 1, 2}, kTruth, kFocal).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(RefinePnp(s.c, {0, 1, 2, 10}, kTruth, kFocal).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(RefinePnp(s.c, AllIndices(10), kTruth, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  Motion nan = kTruth;
  nan.t.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(RefinePnp(s.c, AllIndices(10), nan, kFocal).status().code(),
            absl::StatusCode::kInvalidArgument);
  // Every point behind the start's camera.
  Motion behind = kTruth;
  behind.t.z() -= 20;
  EXPECT_EQ(RefinePnp(s.c, AllIndices(10), behind, kFocal).status().code(),
            absl::StatusCode::kInvalidArgument);
  for (Correspondence& c : s.c) c.reference_point.reset();
  EXPECT_EQ(RefinePnp(s.c, AllIndices(10), kTruth, kFocal).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace waymark::visual_slam

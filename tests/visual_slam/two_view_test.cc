#include "server/visual_slam/geometry/two_view.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::MakeMotion;
using testing::Project;
using testing::SceneMaker;

const Motion kTruth = MakeMotion(2, -5, 1, Eigen::Vector3d(0.3, -0.02, 0.1));

TEST(Triangulate, RecoversKnownPoints) {
  SceneMaker maker(1);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d X = maker.VisiblePoint(kTruth);
    const std::optional<Eigen::Vector3d> got =
        Triangulate(kTruth, Project(X), Project(kTruth.R * X + kTruth.t));
    ASSERT_TRUE(got.has_value()) << X.transpose();
    EXPECT_LT((*got - X).norm(), 1e-9 * X.norm());
  }
}

TEST(Triangulate, ScalesWithTheTranslation) {
  // Monocular: the same pair under a unit-length translation gives the point divided by |t|.
  const Eigen::Vector3d X(0.4, -0.3, 3.5);
  Motion unit = kTruth;
  unit.t.normalize();
  const std::optional<Eigen::Vector3d> got =
      Triangulate(unit, Project(X), Project(kTruth.R * X + kTruth.t));
  ASSERT_TRUE(got.has_value());
  EXPECT_LT((*got - X / kTruth.t.norm()).norm(), 1e-9);
}

TEST(Triangulate, NoisyPairsLandNearTheirPoints) {
  SceneMaker maker(2);
  double worst = 0;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d X = maker.VisiblePoint(kTruth, 2, 4);
    const Correspondence c = maker.Pair(X, kTruth, 0.5);
    const std::optional<Eigen::Vector3d> got = Triangulate(kTruth, c.reference, c.current);
    ASSERT_TRUE(got.has_value());
    worst = std::max(worst, (*got - X).norm() / X.z());
  }
  // 0.5 px at 500 px focal with a 0.3 m baseline at <= 4 m: depth errors of a few percent.
  EXPECT_LT(worst, 0.1);
}

TEST(Triangulate, RejectsParallelRaysAndPointsBehind) {
  const Eigen::Vector3d X(0.2, 0.1, 3);
  // No translation: every ray pair is parallel.
  const Motion rotation = MakeMotion(1, 2, 3, Eigen::Vector3d::Zero());
  EXPECT_FALSE(Triangulate(rotation, Project(X), Project(rotation.R * X)).has_value());
  // A very far point: parallax below the threshold.
  const Eigen::Vector3d far(2, 1, 3000);
  EXPECT_FALSE(Triangulate(kTruth, Project(far), Project(kTruth.R * far + kTruth.t)).has_value());
  // ... but accepted with no parallax threshold.
  EXPECT_TRUE(
      Triangulate(kTruth, Project(far), Project(kTruth.R * far + kTruth.t), 0.0).has_value());
  // The mirrored translation puts the point behind the cameras.
  Motion flipped = kTruth;
  flipped.t = -kTruth.t;
  EXPECT_FALSE(Triangulate(flipped, Project(X), Project(kTruth.R * X + kTruth.t)).has_value());
  // Non-finite input.
  EXPECT_FALSE(Triangulate(kTruth, Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 0),
                           Project(kTruth.R * X + kTruth.t))
                   .has_value());
}

TEST(EpipolarGeometry, SampsonAndLineDistances) {
  Motion sideways;
  sideways.t = Eigen::Vector3d(1, 0, 0);
  const Eigen::Matrix3d E = EssentialOf(sideways);
  EXPECT_TRUE(E.isApprox(Skew(sideways.t)));
  // Horizontal epipolar lines: the line distance is the vertical offset.
  EXPECT_NEAR(EpipolarLineDistance(E, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(-0.3, 0.25)), 0.05,
              1e-12);
  EXPECT_NEAR(SampsonDistance(E, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d(-0.3, 0.2)), 0, 1e-12);
  // Zero E: undefined.
  EXPECT_TRUE(std::isinf(
      SampsonDistance(Eigen::Matrix3d::Zero(), Eigen::Vector2d(0, 0), Eigen::Vector2d(0, 0))));
  EXPECT_TRUE(std::isinf(
      EpipolarLineDistance(Eigen::Matrix3d::Zero(), Eigen::Vector2d(0, 0), Eigen::Vector2d(0, 0))));
}

TEST(PairDepths, DepthsInBothCameras) {
  const Eigen::Vector3d X(0.3, -0.2, 4);
  const Eigen::Vector3d Xc = kTruth.R * X + kTruth.t;
  const std::optional<Eigen::Vector2d> d = PairDepths(kTruth, Project(X), Project(Xc));
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR((*d)(0), X.z(), 1e-9);
  EXPECT_NEAR((*d)(1), Xc.z(), 1e-9);
}

}  // namespace
}  // namespace waymark::visual_slam

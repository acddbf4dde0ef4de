#include "server/visual_slam/geometry/static_test.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "server/visual_slam/geometry/two_view.h"
#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::kFocal;
using testing::MakeMotion;
using testing::SceneMaker;

const Motion kTruth = MakeMotion(1, -3, 0.5, Eigen::Vector3d(0.2, 0.02, 0.1));

StaticTestOptions Options() {
  StaticTestOptions o;
  o.distance_px = 3;
  o.max_hamming = 32;
  o.focal_px = kFocal;
  return o;
}

// RGB-D: 130 points, 33 of which moved 5-20 cm in a random direction between the frames (a
// walking person's points).
TEST(StaticTest, DepthPathFlagsMovedPoints) {
  SceneMaker maker(1);
  std::vector<Correspondence> c;
  std::vector<double> shift_px;  // image displacement the 3-D move caused; 0 = static point
  for (int i = 0; i < 130; ++i) {
    const Eigen::Vector3d X = maker.VisiblePoint(kTruth);
    Correspondence pair = maker.Pair(X, kTruth, 0.5);
    double shift = 0;
    if (i % 4 == 0) {
      Eigen::Vector3d dir(maker.Uniform(-1, 1), maker.Uniform(-1, 1), maker.Uniform(-1, 1));
      const Eigen::Vector3d moved = X + maker.Uniform(0.05, 0.20) * dir.normalized();
      const Eigen::Vector2d seen = testing::Project(kTruth.R * moved + kTruth.t);
      shift = (seen - testing::Project(kTruth.R * X + kTruth.t)).norm() * kFocal;
      pair.current = seen + maker.Noise(0.5);
    }
    c.push_back(pair);
    shift_px.push_back(shift);
  }
  const std::vector<bool> is_static = StaticTest(c, kTruth, Options());
  ASSERT_EQ(is_static.size(), c.size());
  int static_kept = 0, static_total = 0, moved_flagged = 0, moved_total = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    if (shift_px[i] == 0) {
      ++static_total;
      static_kept += is_static[i];
      continue;
    }
    ++moved_total;
    moved_flagged += !is_static[i];
    // A move mostly along the viewing ray barely shows in the image; every move that shows by
    // more than 3 px plus the noise is caught.
    if (shift_px[i] > 5) EXPECT_FALSE(is_static[i]) << i << " moved " << shift_px[i] << " px";
  }
  EXPECT_EQ(static_total, 97);
  EXPECT_EQ(static_kept, static_total);  // 0.5 px noise does not reach 3 px here
  EXPECT_GE(moved_flagged, 0.85 * moved_total) << moved_flagged << " of " << moved_total;
}

// Monocular: no depth, the distance to the epipolar line. Points moved off their line by 5-20 px
// are flagged; points moved along it cannot be (and are not).
TEST(StaticTest, EpipolarPathFlagsPointsOffTheirLine) {
  SceneMaker maker(2);
  Motion unit = kTruth;
  unit.t.normalize();  // monocular translations are directions
  const Eigen::Matrix3d E = Skew(unit.t) * unit.R;
  std::vector<Correspondence> c;
  std::vector<int> kind;  // 0 static, 1 off the line, 2 along the line
  for (int i = 0; i < 120; ++i) {
    Correspondence pair = maker.Pair(maker.VisiblePoint(kTruth), kTruth, 0.5);
    pair.reference_point.reset();
    const Eigen::Vector3d line = E * Eigen::Vector3d(pair.reference.x(), pair.reference.y(), 1);
    const Eigen::Vector2d normal = line.head<2>().normalized();
    const Eigen::Vector2d along(-normal.y(), normal.x());
    const int k = i % 4 == 1 ? 1 : (i % 8 == 3 ? 2 : 0);
    if (k == 1) pair.current += maker.Uniform(5, 20) / kFocal * normal;
    if (k == 2) pair.current += 15 / kFocal * along;
    c.push_back(pair);
    kind.push_back(k);
  }
  const std::vector<bool> is_static = StaticTest(c, unit, Options());
  for (size_t i = 0; i < c.size(); ++i) {
    if (kind[i] == 1) {
      EXPECT_FALSE(is_static[i]) << i;
    } else {
      EXPECT_TRUE(is_static[i]) << i << " at " << PredictionDistancePx(c[i], unit, kFocal) << " px";
    }
  }
  // The metric translation gives the same lines: the test does not depend on |t|.
  EXPECT_EQ(StaticTest(c, kTruth, Options()), is_static);
}

TEST(StaticTest, HammingRule) {
  Correspondence c;
  c.reference_point = Eigen::Vector3d(0.1, 0.2, 2);
  c.current = testing::Project(kTruth.R * *c.reference_point + kTruth.t);
  std::vector<Correspondence> pairs(3, c);
  pairs[0].hamming = 31;
  pairs[1].hamming = 32;  // delta / 2 itself is not below delta / 2
  pairs[2].hamming = 200;
  EXPECT_EQ(StaticTest(pairs, kTruth, Options()), (std::vector<bool>{true, false, false}));
  EXPECT_NEAR(PredictionDistancePx(pairs[0], kTruth, kFocal), 0, 1e-9);
}

TEST(StaticTest, DistanceThresholdIsInclusive) {
  Correspondence c;
  c.reference_point = Eigen::Vector3d(0, 0, 2);
  c.current = Eigen::Vector2d(3 / kFocal, 0);  // identity motion: exactly 3 px away
  const Motion identity;
  EXPECT_NEAR(PredictionDistancePx(c, identity, kFocal), 3, 1e-9);
  StaticTestOptions o = Options();
  o.distance_px = 3 + 1e-9;
  EXPECT_TRUE(StaticTest({c}, identity, o)[0]);
  o.distance_px = 2.99;
  EXPECT_FALSE(StaticTest({c}, identity, o)[0]);
}

TEST(StaticTest, RotationOnlyAndBehindTheCamera) {
  // No translation and no depth: the prediction is R * reference.
  const Motion rotation = MakeMotion(0, 2, 0, Eigen::Vector3d::Zero());
  Correspondence c;
  c.reference = Eigen::Vector2d(0.05, -0.1);
  const Eigen::Vector3d x = rotation.R * Eigen::Vector3d(0.05, -0.1, 1);
  c.current = x.head<2>() / x.z() + Eigen::Vector2d(0, 4 / kFocal);  // 4 px below
  EXPECT_NEAR(PredictionDistancePx(c, rotation, kFocal), 4, 1e-9);
  EXPECT_FALSE(StaticTest({c}, rotation, Options())[0]);
  c.current.y() -= 4 / kFocal;
  EXPECT_TRUE(StaticTest({c}, rotation, Options())[0]);

  // A reference point that the motion puts behind the current camera is not static.
  Correspondence behind;
  behind.reference_point = Eigen::Vector3d(0, 0, 1);
  Motion back;
  back.t = Eigen::Vector3d(0, 0, -2);
  EXPECT_TRUE(std::isinf(PredictionDistancePx(behind, back, kFocal)));
  EXPECT_FALSE(StaticTest({behind}, back, Options())[0]);
  EXPECT_TRUE(StaticTest({}, back, Options()).empty());
}

}  // namespace
}  // namespace waymark::visual_slam

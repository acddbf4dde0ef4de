// The local bundle adjustment on synthetic scenes with known answers: cameras along a forward
// drive, points in front of them, pixel noise in the observations. The start is the truth moved
// (poses and points); the adjustment must bring it back, keep the fixed cameras exactly where they
// are (the gauge), resist gross outliers (Huber) and name them.

#include "server/visual_slam/mapping/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::kFocal;
using testing::RotationErrorDeg;

struct Scene {
  std::vector<Pose> cameras;
  std::vector<Eigen::Vector3d> points;
  BundleProblem problem;  // observations with noise; cameras and points at the truth
};

// `cameras` cameras 1 m apart along z, turning 2 degrees each; `points` points 4-30 m ahead.
Scene MakeScene(int cameras, int points, double noise_px, bool with_depth, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-12, 12), height(-3, 3), ahead(4, 30);
  std::normal_distribution<double> noise(0, noise_px / kFocal);
  Scene scene;
  for (int i = 0; i < cameras; ++i) {
    Pose pose;
    pose.R = Eigen::AngleAxisd(i * 2.0 * testing::kPi / 180, Eigen::Vector3d::UnitY())
                 .toRotationMatrix();
    pose.t = Eigen::Vector3d(0.1 * i, 0, 1.0 * i);
    scene.cameras.push_back(pose);
    scene.problem.cameras.push_back({pose, false});
  }
  while (static_cast<int>(scene.points.size()) < points) {
    const Eigen::Vector3d X(lateral(rng), height(rng), ahead(rng) + cameras);
    std::vector<BundleObservation> seen;
    for (int c = 0; c < cameras; ++c) {
      const Eigen::Vector3d p = scene.cameras[c].R.transpose() * (X - scene.cameras[c].t);
      if (!testing::InImage(p)) continue;
      BundleObservation o;
      o.camera = c;
      o.point = static_cast<int>(scene.points.size());
      o.normalized = p.head<2>() / p.z() + Eigen::Vector2d(noise(rng), noise(rng));
      if (with_depth) o.depth = p.z() * (1 + 0.005 * noise(rng) * kFocal);
      seen.push_back(o);
    }
    if (seen.size() < 2) continue;
    scene.points.push_back(X);
    scene.problem.points.push_back(X);
    scene.problem.observations.insert(scene.problem.observations.end(), seen.begin(), seen.end());
  }
  return scene;
}

// Moves every camera not fixed and every point away from the truth.
void Perturb(BundleProblem& problem, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> position(0, 0.15), angle(0, 1.5 * testing::kPi / 180);
  for (BundleCamera& camera : problem.cameras) {
    if (camera.fixed) continue;
    camera.pose.t += Eigen::Vector3d(position(rng), position(rng), position(rng));
    camera.pose.R = camera.pose.R * (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitX()) *
                                     Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitY()))
                                        .toRotationMatrix();
  }
  for (Eigen::Vector3d& point : problem.points) {
    point += Eigen::Vector3d(position(rng), position(rng), 3 * position(rng));
  }
}

BundleOptions Options() {
  BundleOptions options;
  options.focal_px = kFocal;
  options.max_iterations = 50;
  return options;
}

double WorstPositionError(const std::vector<Pose>& a, const std::vector<Pose>& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (a[i].t - b[i].t).norm());
  return worst;
}

double WorstRotationErrorDeg(const std::vector<Pose>& a, const std::vector<Pose>& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, RotationErrorDeg(a[i].R, b[i].R));
  return worst;
}

TEST(BundleAdjustmentTest, MonocularWithTwoFixedCamerasRecoversPosesPointsAndScale) {
  Scene scene = MakeScene(6, 300, 0.5, /*with_depth=*/false, 1);
  scene.problem.cameras[0].fixed = true;
  scene.problem.cameras[1].fixed = true;  // the second fixes the scale
  Perturb(scene.problem, 2);
  ASSERT_GT(WorstPositionError(
                [&] {
                  std::vector<Pose> start;
                  for (const BundleCamera& c : scene.problem.cameras) start.push_back(c.pose);
                  return start;
                }(),
                scene.cameras),
            0.1);

  absl::StatusOr<BundleResult> result = BundleAdjust(scene.problem, Options());
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_LT(result->final_cost, 0.01 * result->initial_cost);
  EXPECT_LT(WorstPositionError(result->cameras, scene.cameras), 0.02);
  EXPECT_LT(WorstRotationErrorDeg(result->cameras, scene.cameras), 0.05);
  for (int i : {0, 1}) {  // the gauge does not move, to the last bit
    EXPECT_EQ(result->cameras[i].t, scene.cameras[i].t);
    EXPECT_EQ(result->cameras[i].R, scene.cameras[i].R);
  }
  int outliers = 0;
  for (bool o : result->outlier) outliers += o;
  EXPECT_EQ(outliers, 0);
}

TEST(BundleAdjustmentTest, DepthFixesTheScaleWithOneFixedCamera) {
  Scene scene = MakeScene(5, 200, 0.5, /*with_depth=*/true, 3);
  scene.problem.cameras[0].fixed = true;
  // Start at the wrong scale: everything 30 % farther from the fixed camera, then moved.
  const Eigen::Vector3d origin = scene.cameras[0].t;
  for (size_t i = 1; i < scene.problem.cameras.size(); ++i) {
    scene.problem.cameras[i].pose.t = origin + 1.3 * (scene.problem.cameras[i].pose.t - origin);
  }
  for (Eigen::Vector3d& point : scene.problem.points) point = origin + 1.3 * (point - origin);
  Perturb(scene.problem, 4);
  absl::StatusOr<BundleResult> result = BundleAdjust(scene.problem, Options());
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_LT(WorstPositionError(result->cameras, scene.cameras), 0.02);
  EXPECT_LT(WorstRotationErrorDeg(result->cameras, scene.cameras), 0.05);

  // Without the depth residual one fixed camera leaves the scale free: reprojections alone do
  // not bring the cameras back to metric positions (what the depth residual is for).
  BundleOptions without_depth = Options();
  without_depth.stereo_bf = 0;
  absl::StatusOr<BundleResult> free_scale = BundleAdjust(scene.problem, without_depth);
  ASSERT_TRUE(free_scale.ok());
  EXPECT_GT(WorstPositionError(free_scale->cameras, scene.cameras), 0.3);
}

TEST(BundleAdjustmentTest, GrossOutliersAreNamedAndDoNotSpoilTheAnswer) {
  Scene scene = MakeScene(6, 300, 0.5, /*with_depth=*/false, 5);
  scene.problem.cameras[0].fixed = true;
  scene.problem.cameras[1].fixed = true;
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> offset(-60 / kFocal, 60 / kFocal);
  std::vector<bool> corrupted(scene.problem.observations.size(), false);
  for (size_t k = 0; k < scene.problem.observations.size(); k += 10) {  // 10 %: 20-60 px off
    Eigen::Vector2d shift(offset(rng), offset(rng));
    if (shift.norm() * kFocal < 20) shift *= 20 / (shift.norm() * kFocal);
    scene.problem.observations[k].normalized += shift;
    corrupted[k] = true;
  }
  Perturb(scene.problem, 7);
  absl::StatusOr<BundleResult> result = BundleAdjust(scene.problem, Options());
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_LT(WorstPositionError(result->cameras, scene.cameras), 0.05);
  EXPECT_LT(WorstRotationErrorDeg(result->cameras, scene.cameras), 0.1);
  int caught = 0, false_alarms = 0, bad = 0;
  for (size_t k = 0; k < corrupted.size(); ++k) {
    bad += corrupted[k];
    caught += corrupted[k] && result->outlier[k];
    false_alarms += !corrupted[k] && result->outlier[k];
  }
  EXPECT_GE(caught, 0.9 * bad);
  EXPECT_LE(false_alarms, 0.02 * (corrupted.size() - bad));
}

TEST(BundleAdjustmentTest, RefusesAFreeGaugeAndBadInput) {
  Scene scene = MakeScene(3, 50, 0.5, false, 8);
  EXPECT_TRUE(absl::IsInvalidArgument(BundleAdjust(scene.problem, Options()).status()));
  scene.problem.cameras[0].fixed = true;
  BundleProblem out_of_range = scene.problem;
  out_of_range.observations[0].point = static_cast<int>(out_of_range.points.size());
  EXPECT_TRUE(absl::IsInvalidArgument(BundleAdjust(out_of_range, Options()).status()));
  BundleProblem not_finite = scene.problem;
  not_finite.points[0].x() = std::nan("");
  EXPECT_TRUE(absl::IsInvalidArgument(BundleAdjust(not_finite, Options()).status()));
  // A point behind a camera at the start is left out and reported, not a failure.
  BundleProblem behind = scene.problem;
  behind.points[0] = behind.cameras[0].pose.t - Eigen::Vector3d(0, 0, 5);
  absl::StatusOr<BundleResult> result = BundleAdjust(behind, Options());
  ASSERT_TRUE(result.ok()) << result.status();
  for (size_t k = 0; k < behind.observations.size(); ++k) {
    if (behind.observations[k].point == 0 && behind.observations[k].camera == 0) {
      EXPECT_TRUE(result->outlier[k]);
    }
  }
}

}  // namespace
}  // namespace waymark::visual_slam

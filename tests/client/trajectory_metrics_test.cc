// ATE / RPE math on constructed trajectories with known answers: alignment recovery (rigid and
// similarity), known noise, constant per-step drift, and timestamp association.
#include "client/eval/trajectory_metrics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;

Eigen::Matrix3d Rot(double angle, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

// A 3-D wiggly helix with changing orientation, one pose every 0.1 s from t = 1000.
std::vector<StampedPose3> Helix(int n) {
  std::vector<StampedPose3> poses;
  for (int i = 0; i < n; ++i) {
    StampedPose3 p;
    p.stamp = 1000.0 + 0.1 * i;
    p.translation = Eigen::Vector3d(std::cos(0.2 * i), std::sin(0.2 * i), 0.05 * i) * 2.0 +
                    Eigen::Vector3d(0.3 * std::sin(0.7 * i), 0, 0);
    p.rotation = Rot(0.1 * i, {0, 0, 1}) * Rot(0.3 * std::sin(0.15 * i), {1, 0.2, 0});
    poses.push_back(p);
  }
  return poses;
}

// x -> s R x + t applied to a trajectory (rotations R * rotation).
std::vector<StampedPose3> Transform(const std::vector<StampedPose3>& poses,
                                    const Eigen::Matrix3d& r, const Eigen::Vector3d& t,
                                    double s = 1.0) {
  std::vector<StampedPose3> out = poses;
  for (StampedPose3& p : out) {
    p.translation = s * r * p.translation + t;
    p.rotation = r * p.rotation;
  }
  return out;
}

TEST(ErrorStats, KnownValues) {
  const ErrorStats s = ComputeErrorStats({4, 1, 3, 2});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.max, 4);
  EXPECT_DOUBLE_EQ(ComputeErrorStats({5, 1, 3}).median, 3);
  EXPECT_EQ(ComputeErrorStats({}).count, 0u);
}

TEST(RotationAngle, KnownAngles) {
  EXPECT_NEAR(RotationAngle(Eigen::Matrix3d::Identity()), 0, 1e-12);
  EXPECT_NEAR(RotationAngle(Rot(0.7, {1, 2, 3})), 0.7, 1e-12);
  EXPECT_NEAR(RotationAngle(Rot(kPi, {0, 1, 0})), kPi, 1e-7);
}

TEST(AlignUmeyama, RecoversRigidTransform) {
  std::vector<Eigen::Vector3d> source;
  std::vector<Eigen::Vector3d> target;
  const Eigen::Matrix3d r = Rot(1.1, {0.3, -1, 0.5});
  const Eigen::Vector3d t(4, -2, 0.5);
  for (const StampedPose3& p : Helix(40)) {
    source.push_back(p.translation);
    target.push_back(r * p.translation + t);
  }
  auto a = AlignUmeyama(source, target, false);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_TRUE(a->rotation.isApprox(r, 1e-9));
  EXPECT_TRUE(a->translation.isApprox(t, 1e-9));
  EXPECT_DOUBLE_EQ(a->scale, 1.0);
}

TEST(AlignUmeyama, RecoversSimilarity) {
  std::vector<Eigen::Vector3d> source;
  std::vector<Eigen::Vector3d> target;
  const Eigen::Matrix3d r = Rot(-2.0, {1, 1, 0});
  const Eigen::Vector3d t(-1, 7, 3);
  for (const StampedPose3& p : Helix(40)) {
    source.push_back(p.translation);
    target.push_back(3.5 * r * p.translation + t);
  }
  auto a = AlignUmeyama(source, target, true);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_NEAR(a->scale, 3.5, 1e-9);
  EXPECT_TRUE(a->rotation.isApprox(r, 1e-9));
  EXPECT_TRUE(a->translation.isApprox(t, 1e-9));
}

TEST(AlignUmeyama, MirroredTargetStillGivesAProperRotation) {
  std::vector<Eigen::Vector3d> source;
  std::vector<Eigen::Vector3d> target;
  for (const StampedPose3& p : Helix(30)) {
    source.push_back(p.translation);
    target.push_back(Eigen::Vector3d(-p.translation.x(), p.translation.y(), p.translation.z()));
  }
  auto a = AlignUmeyama(source, target, false);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_NEAR(a->rotation.determinant(), 1.0, 1e-9);
  EXPECT_TRUE((a->rotation.transpose() * a->rotation).isIdentity(1e-9));
}

TEST(AlignUmeyama, RefusesTooFewOrMismatchedOrDegenerate) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_EQ(AlignUmeyama(two, two, false).status().code(), absl::StatusCode::kFailedPrecondition);
  const std::vector<Eigen::Vector3d> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_EQ(AlignUmeyama(three, two, false).status().code(), absl::StatusCode::kInvalidArgument);
  const std::vector<Eigen::Vector3d> same = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  EXPECT_EQ(AlignUmeyama(same, three, true).status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST(EvaluateTrajectory, RotatedAndTranslatedCopyHasZeroError) {
  const auto gt = Helix(80);
  const Eigen::Matrix3d r = Rot(0.8, {1, -2, 0.5});
  const auto est = Transform(gt, r, Eigen::Vector3d(10, -3, 2));
  auto e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->matches.size(), 80u);
  EXPECT_LT(e->ate.rmse, 1e-9);
  EXPECT_LT(e->ate.max, 1e-9);
  EXPECT_LT(e->rpe_translation.rmse, 1e-9);
  EXPECT_LT(e->rpe_rotation_deg.rmse, 1e-5);
  EXPECT_TRUE(e->alignment.rotation.isApprox(r.transpose(), 1e-9));
  EXPECT_DOUBLE_EQ(e->alignment.scale, 1.0);
}

TEST(EvaluateTrajectory, ScaledCopyNeedsScaleAlignment) {
  const auto gt = Helix(80);
  const auto est = Transform(gt, Rot(-0.4, {0, 1, 1}), Eigen::Vector3d(1, 2, 3), 0.25);
  TrajectoryOptions options;
  options.with_scale = true;
  auto e = EvaluateTrajectory(est, gt, options);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_NEAR(e->alignment.scale, 4.0, 1e-9);
  EXPECT_LT(e->ate.rmse, 1e-9);
  EXPECT_LT(e->rpe_translation.rmse, 1e-9);
  EXPECT_LT(e->rpe_rotation_deg.rmse, 1e-5);

  auto rigid = EvaluateTrajectory(est, gt);  // without scale the shrunken copy cannot fit
  ASSERT_TRUE(rigid.ok());
  EXPECT_GT(rigid->ate.rmse, 0.5);
  EXPECT_GT(rigid->rpe_translation.rmse, 0.1);
}

// Noise that leaves the optimal alignment unchanged: positions come in pairs at the same place
// and the two noise vectors of a pair are opposite, so the noise has zero mean and zero
// correlation with the positions. Every ATE error is then exactly the noise length.
TEST(EvaluateTrajectory, KnownNoiseGivesKnownRmse) {
  const auto base = Helix(60);
  std::vector<StampedPose3> gt;
  std::vector<StampedPose3> noisy;
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  std::vector<double> lengths;
  for (size_t m = 0; m < base.size(); ++m) {
    const double length = 0.01 * (1 + m % 4);
    const Eigen::Vector3d e =
        Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() * length;
    for (int k = 0; k < 2; ++k) {
      StampedPose3 g = base[m];
      g.stamp = 1000.0 + 0.05 * static_cast<double>(2 * m + k);
      gt.push_back(g);
      g.translation += k == 0 ? e : Eigen::Vector3d(-e);
      noisy.push_back(g);
      lengths.push_back(length);
    }
  }
  const ErrorStats expected = ComputeErrorStats(lengths);
  const auto est = Transform(noisy, Rot(2.2, {0.1, 0.4, -1}), Eigen::Vector3d(-5, 5, 1));
  auto e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_NEAR(e->ate.rmse, expected.rmse, 1e-9);
  EXPECT_NEAR(e->ate.mean, expected.mean, 1e-9);
  EXPECT_NEAR(e->ate.std, expected.std, 1e-9);
  EXPECT_NEAR(e->ate.median, expected.median, 1e-9);
  EXPECT_NEAR(e->ate.max, 0.04, 1e-9);
}

// est_{k+1} = est_k (gt_k^-1 gt_{k+1}) D: every delta-1 relative error is exactly D.
TEST(EvaluateTrajectory, ConstantPerStepErrorGivesConstantRpe) {
  const auto gt = Helix(50);
  const Eigen::Matrix3d d_rot = Rot(0.5 * kPi / 180.0, {0.2, 1, 0.3});
  const Eigen::Vector3d d_t(0.01, -0.02, 0.005);
  std::vector<StampedPose3> est = {gt[0]};
  for (size_t k = 0; k + 1 < gt.size(); ++k) {
    const Eigen::Matrix3d rel_r = gt[k].rotation.transpose() * gt[k + 1].rotation;
    const Eigen::Vector3d rel_t =
        gt[k].rotation.transpose() * (gt[k + 1].translation - gt[k].translation);
    // (rel_r, rel_t) * (d_rot, d_t)
    const Eigen::Matrix3d step_r = rel_r * d_rot;
    const Eigen::Vector3d step_t = rel_r * d_t + rel_t;
    StampedPose3 next;
    next.stamp = gt[k + 1].stamp;
    next.rotation = est.back().rotation * step_r;
    next.translation = est.back().rotation * step_t + est.back().translation;
    est.push_back(next);
  }
  auto e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->rpe_translation.count, 49u);
  EXPECT_NEAR(e->rpe_translation.rmse, d_t.norm(), 1e-9);
  EXPECT_NEAR(e->rpe_translation.mean, d_t.norm(), 1e-9);
  EXPECT_NEAR(e->rpe_translation.std, 0, 1e-9);
  EXPECT_NEAR(e->rpe_rotation_deg.rmse, 0.5, 1e-6);
  EXPECT_NEAR(e->rpe_rotation_deg.mean, 0.5, 1e-6);
  EXPECT_GT(e->ate.rmse, 0.01);  // the drift accumulates in the absolute error
}

// Pure translations with a constant extra step d: RPE over delta frames is delta * |d|.
TEST(EvaluateTrajectory, DeltaSpansSeveralMatchedPoses) {
  std::vector<StampedPose3> gt;
  std::vector<StampedPose3> est;
  const Eigen::Vector3d d(0.003, 0.004, 0);  // |d| = 0.005
  for (int i = 0; i < 30; ++i) {
    StampedPose3 g;
    g.stamp = 5.0 + 0.1 * i;
    g.translation = Eigen::Vector3d(0.1 * i, std::sin(0.3 * i), 0.02 * i * i);
    gt.push_back(g);
    g.translation += i * d;
    est.push_back(g);
  }
  TrajectoryOptions options;
  options.delta = 3;
  auto e = EvaluateTrajectory(est, gt, options);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->rpe_translation.count, 27u);
  // RPE is invariant to the rigid alignment, so every error is exactly 3 d.
  EXPECT_NEAR(e->rpe_translation.rmse, 0.015, 1e-9);
  EXPECT_NEAR(e->rpe_translation.std, 0, 1e-9);
  EXPECT_NEAR(e->rpe_rotation_deg.rmse, 0, 1e-6);
}

TEST(AssociateByStamp, NearestWithinMaxDtEachUsedOnce) {
  // Ground truth at 100 Hz with a gap, estimate at ~30 Hz with jitter.
  std::vector<double> gt;
  for (int i = 0; i < 100; ++i) {
    if (i >= 40 && i < 60) continue;  // 0.4 .. 0.59 s missing
    gt.push_back(10.0 + 0.01 * i);
  }
  std::vector<double> est;
  const double jitter[] = {0.002, -0.003, 0.001, 0.0};
  for (int i = 0; i < 30; ++i) est.push_back(10.0 + i / 30.0 + jitter[i % 4]);
  const double max_dt = 0.01;
  const auto matches = AssociateByStamp(est, gt, max_dt);
  for (const PoseMatch& m : matches) {
    EXPECT_LE(std::abs(est[m.estimate] - gt[m.groundtruth]), max_dt + 1e-12);
  }
  for (size_t k = 1; k < matches.size(); ++k) {
    EXPECT_LT(est[matches[k - 1].estimate], est[matches[k].estimate]);
    EXPECT_LT(gt[matches[k - 1].groundtruth], gt[matches[k].groundtruth]);
  }
  // Estimates are 33 ms apart, so none compete for a ground-truth pose: every estimate with a
  // ground-truth stamp within max_dt is matched (all but those in the gap).
  size_t expected = 0;
  for (double t : est) {
    bool near = false;
    for (double g : gt) near = near || std::abs(t - g) <= max_dt;
    expected += near ? 1 : 0;
  }
  EXPECT_EQ(matches.size(), expected);
  EXPECT_EQ(expected, 24u);  // 6 of the 30 estimates fall in the 0.4 .. 0.59 s gap
  EXPECT_LT(matches.size(), est.size());
}

TEST(AssociateByStamp, GreedyByTimeDifference) {
  // Both estimates are closest to gt 1.00; the closer one gets it, the other takes 1.03.
  const std::vector<double> est = {1.004, 1.012};
  const std::vector<double> gt = {1.03, 1.00};  // unsorted on purpose
  const auto matches = AssociateByStamp(est, gt, 0.02);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].estimate, 0u);
  EXPECT_EQ(matches[0].groundtruth, 1u);
  EXPECT_EQ(matches[1].estimate, 1u);
  EXPECT_EQ(matches[1].groundtruth, 0u);
  EXPECT_TRUE(AssociateByStamp(est, gt, 0.001).empty());
}

TEST(EvaluateTrajectory, TooFewMatchesSaysHowManyAndTheRanges) {
  const auto gt = Helix(20);
  auto est = gt;
  for (StampedPose3& p : est) p.stamp += 50.0;
  est[0].stamp = gt[3].stamp + 0.001;
  auto e = EvaluateTrajectory(est, gt);
  ASSERT_EQ(e.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(e.status().message(), HasSubstr("only 1 poses matched"));
  EXPECT_THAT(e.status().message(), HasSubstr("1000.000000 .. 1001.900000"));
  EXPECT_THAT(e.status().message(), HasSubstr("1051.900000"));

  TrajectoryOptions bad;
  bad.delta = 0;
  EXPECT_EQ(EvaluateTrajectory(gt, gt, bad).status().code(), absl::StatusCode::kInvalidArgument);
}

// The issue-15 case: a trajectory stamped at 10 Hz against poses stamped 1 s apart matches only
// where the two clocks coincide (6 of 51 poses). The ATE is computed, but must not pass silently.
TEST(EvaluateTrajectory, FewMatchesWarnWithBothStampSpans) {
  std::vector<StampedPose3> est = Helix(51);
  std::vector<StampedPose3> gt = est;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].stamp = 0.1 * static_cast<double>(i);
    gt[i].stamp = static_cast<double>(i);
  }
  auto e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->matches.size(), 6u);
  const std::optional<std::string> warning = FewMatchesWarning(*e);
  ASSERT_TRUE(warning.has_value());
  EXPECT_THAT(*warning, HasSubstr("only 6 of 51 poses matched"));
  EXPECT_THAT(*warning, HasSubstr("estimate has 51 poses, stamps 0.000000 .. 5.000000"));
  EXPECT_THAT(*warning, HasSubstr("ground truth has 51 poses, stamps 0.000000 .. 50.000000"));

  // Half of the shorter trajectory is enough: a 20-pose estimate of a 200-pose ground truth.
  gt = Helix(200);
  est.assign(gt.begin(), gt.begin() + 20);
  e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->matches.size(), 20u);
  EXPECT_FALSE(FewMatchesWarning(*e).has_value());
  for (size_t i = 10; i < est.size(); ++i) est[i].stamp += 100;  // 10 of 20 still match
  e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(FewMatchesWarning(*e).has_value());
  est[9].stamp += 100;  // 9 of 20
  e = EvaluateTrajectory(est, gt);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_TRUE(FewMatchesWarning(*e).has_value());
}

}  // namespace
}  // namespace waymark::cli

// The relations metric (Kummerle et al. 2009) on constructed cases, and the TUM reader/writer.
#include "client/eval/relations_metric.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A wiggly path, one pose every 0.1 s.
std::vector<StampedPose> Path(int n) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    const double t = 100.0 + 0.1 * i;
    poses.push_back({t, {0.3 * i, std::sin(0.2 * i), NormalizeAngle(0.15 * i)}});
  }
  return poses;
}

// True relations between pose i and pose i + gap, from the same path.
std::vector<Relation> Relations(const std::vector<StampedPose>& truth, int gap) {
  std::vector<Relation> relations;
  for (size_t i = 0; i + gap < truth.size(); ++i) {
    relations.push_back({truth[i].stamp, truth[i + gap].stamp,
                         Compose(Inverse(truth[i].pose), truth[i + gap].pose)});
  }
  return relations;
}

TEST(RelationsMetric, PerfectTrajectoryHasZeroError) {
  const auto truth = Path(50);
  const RelationsResult r = EvaluateRelations(truth, Relations(truth, 3));
  EXPECT_EQ(r.relations, 47);
  EXPECT_EQ(r.relations_used, 47);
  EXPECT_NEAR(r.trans_abs.mean, 0, 1e-12);
  EXPECT_NEAR(r.rot_abs_deg.mean, 0, 1e-9);
  EXPECT_NEAR(r.trans_sq.mean, 0, 1e-20);
}

TEST(RelationsMetric, AGlobalRigidMotionDoesNotMatter) {
  const auto truth = Path(30);
  std::vector<StampedPose> moved = truth;
  for (StampedPose& p : moved) p.pose = Compose({5, -3, 1.0}, p.pose);
  const RelationsResult r = EvaluateRelations(moved, Relations(truth, 5));
  EXPECT_NEAR(r.trans_abs.mean, 0, 1e-9);
  EXPECT_NEAR(r.rot_abs_deg.mean, 0, 1e-7);
}

TEST(RelationsMetric, KnownYawOffsetGivesKnownErrors) {
  // The estimate turns 2 degrees more than the truth between t1 and t2, after driving 1 m
  // straight: e = inv(delta*) (+) delta_est = (0, 0, 2 deg) for every relation.
  // Then a 1 m translation error on half of the relations.
  std::vector<StampedPose> estimate = {{1.0, {0, 0, 0}}, {2.0, {1, 0, 2 * kPi / 180}},
                                       {3.0, {0, 0, 0}}, {4.0, {2, 0, 0}}};
  std::vector<Relation> relations = {{1.0, 2.0, {1, 0, 0}}, {3.0, 4.0, {1, 0, 0}}};
  const RelationsResult r = EvaluateRelations(estimate, relations);
  ASSERT_EQ(r.relations_used, 2);
  EXPECT_NEAR(r.trans_errors[0], 0, 1e-12);
  EXPECT_NEAR(r.rot_errors_deg[0], 2.0, 1e-9);
  EXPECT_NEAR(r.trans_errors[1], 1.0, 1e-12);
  EXPECT_NEAR(r.rot_errors_deg[1], 0, 1e-9);
  EXPECT_NEAR(r.trans_abs.mean, 0.5, 1e-12);
  EXPECT_NEAR(r.trans_abs.std, 0.5, 1e-12);  // population std of {0, 1}
  EXPECT_NEAR(r.trans_sq.mean, 0.5, 1e-12);
  EXPECT_NEAR(r.rot_abs_deg.mean, 1.0, 1e-9);
  EXPECT_NEAR(r.rot_abs_deg.std, 1.0, 1e-9);
  EXPECT_NEAR(r.rot_sq_deg2.mean, 2.0, 1e-8);
  EXPECT_NEAR(r.rot_sq_deg2.std, 2.0, 1e-8);
  EXPECT_NEAR(r.trans_abs_max, 1.0, 1e-12);
}

TEST(RelationsMetric, RotationErrorIsNormalised) {
  // True turn +179 deg, estimated -179 deg: 2 degrees apart, not 358.
  std::vector<StampedPose> estimate = {{1.0, {0, 0, 0}}, {2.0, {0, 0, -179 * kPi / 180}}};
  const RelationsResult r =
      EvaluateRelations(estimate, {{1.0, 2.0, {0, 0, 179 * kPi / 180}}});
  EXPECT_NEAR(r.rot_abs_deg.mean, 2.0, 1e-9);
}

TEST(RelationsMetric, MissingPosesAreCountedAndToleranceApplies) {
  std::vector<StampedPose> estimate = {{1.0, {0, 0, 0}}, {2.0004, {1, 0, 0}}, {3.0, {2, 0, 0}}};
  std::vector<Relation> relations = {
      {1.0, 2.0, {1, 0, 0}},    // 0.4 ms off: found with the 1 ms default
      {1.0, 2.5, {1, 0, 0}},    // no pose at t2
      {0.5, 3.0, {1, 0, 0}},    // no pose at t1
      {2.9995, 1.0, {-2, 0, 0}},  // reversed order is fine
  };
  RelationsResult r = EvaluateRelations(estimate, relations);
  EXPECT_EQ(r.relations, 4);
  EXPECT_EQ(r.relations_used, 2);
  EXPECT_EQ(r.missing_t1, 1);
  EXPECT_EQ(r.missing_t2, 1);
  EXPECT_NEAR(r.trans_abs.mean, 0, 1e-12);
  r = EvaluateRelations(estimate, relations, 1e-4);
  EXPECT_EQ(r.relations_used, 0);
  const nlohmann::json json = RelationsResultToJson(EvaluateRelations(estimate, relations));
  for (const char* key : {"relations", "relations_used", "trans_abs_mean", "trans_abs_std",
                          "rot_abs_mean_deg", "rot_abs_std_deg", "trans_sq_mean", "trans_sq_std",
                          "rot_sq_mean_deg2", "rot_sq_std_deg2"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
  EXPECT_EQ(json["relations_missing_pose"], 2);
}

TEST(RelationsMetric, ParsesRelationsFiles) {
  auto relations = ParseRelations(
      "# comment\n90.239599 90.719599 0.422330 -0.000750 0.000000 0.000000 0.000000 0.017260\n\n");
  ASSERT_TRUE(relations.ok()) << relations.status();
  ASSERT_EQ(relations->size(), 1u);
  EXPECT_DOUBLE_EQ((*relations)[0].t2, 90.719599);
  EXPECT_DOUBLE_EQ((*relations)[0].delta.x, 0.422330);
  EXPECT_DOUBLE_EQ((*relations)[0].delta.theta, 0.017260);
  auto bad = ParseRelations("1 2 3\n");
  EXPECT_EQ(bad.status().message(),
            "line 1: expected 8 fields (t1 t2 x y z roll pitch yaw), got 3");
}

TEST(TumTrajectory, RoundTrip) {
  std::vector<StampedPose> poses = {{976052857.337530, {1.5, -2.25, 3.0}},
                                    {976052857.348896, {-0.001, 1e-4, -3.1}},
                                    {976052858.0, {0, 0, 0}}};
  std::ostringstream out;
  WriteTum(out, poses);
  auto back = ParseTum(out.str());
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR((*back)[i].stamp, poses[i].stamp, 1e-6);
    EXPECT_NEAR((*back)[i].pose.x, poses[i].pose.x, 1e-6);
    EXPECT_NEAR((*back)[i].pose.y, poses[i].pose.y, 1e-6);
    EXPECT_NEAR(NormalizeAngle((*back)[i].pose.theta - poses[i].pose.theta), 0, 1e-8);
  }
  // Eight fields per pose line.
  std::istringstream lines(out.str());
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line[0], '#');
  std::getline(lines, line);
  std::istringstream fields(line);
  int count = 0;
  for (std::string f; fields >> f;) ++count;
  EXPECT_EQ(count, 8);
}

TEST(TumTrajectory, ReadsYawFromAnyQuaternionAndReportsBadLines) {
  // 90 deg about z.
  auto poses = ParseTum("1.0 0 0 0 0 0 0.7071068 0.7071068\n");
  ASSERT_TRUE(poses.ok());
  EXPECT_NEAR((*poses)[0].pose.theta, kPi / 2, 1e-6);
  auto bad = ParseTum("1 2 3 4 5 6 7 8\n1 2 3\n");
  EXPECT_EQ(bad.status().message(), "line 2: expected 8 fields (t x y z qx qy qz qw), got 3");
  auto nan = ParseTum("1 nan 0 0 0 0 0 1\n");
  EXPECT_FALSE(nan.ok());
}

}  // namespace
}  // namespace waymark::cli

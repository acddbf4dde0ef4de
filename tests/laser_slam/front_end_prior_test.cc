// The front end's prior (issue 33, fourth part): what the session learns of the EKF's steps from
// their disagreement with the local matches (ekf_step_agreement.h), matches whose best pose lies
// on their window's edge, a turn the odometry did not see (issue 33, tenth part), and an EKF
// jump on a scan the local map cannot place.

#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/ekf_step_agreement.h"
#include "server/laser_slam/mapping/local_matcher.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::Wall;

// Steps whose EKF and match errors are drawn with these sigmas (x only), the match reporting its
// own variance truthfully.
EkfStepAgreement Learned(double ekf_sigma, double match_sigma, int steps, std::mt19937* rng) {
  std::normal_distribution<double> ekf(0.0, ekf_sigma), match(0.0, match_sigma);
  EkfStepAgreement agreement;
  for (int i = 0; i < steps; ++i) {
    agreement.Add(Eigen::Vector3d(ekf(*rng) - match(*rng), 0.0, 0.0),
                  Eigen::Vector3d(match_sigma * match_sigma, 1.0, 1.0), Eigen::Array3i(1, 0, 0));
  }
  return agreement;
}

TEST(EkfStepAgreementTest, LearnsWhichOfTheTwoStepsIsBetter) {
  std::mt19937 rng(7);
  // An EKF 4x better than the matches (the simulator's straight walls): its learned variance
  // stays below the matches', near its floor.
  const EkfStepAgreement good = Learned(0.005, 0.02, 400, &rng);
  ASSERT_TRUE(good.EkfVariance(0, 1e-6).has_value());
  EXPECT_LT(*good.EkfVariance(0, 1e-6), *good.MatchVariance(0));
  EXPECT_NEAR(*good.MatchVariance(0), 0.02 * 0.02, 1e-12);
  // An EKF 3x worse (a real log's wrong associations): its variance comes out as its own,
  // within the sampling error of a 100-step memory, and above the matches'.
  const EkfStepAgreement bad = Learned(0.03, 0.01, 400, &rng);
  const double learned = *bad.EkfVariance(0, 1e-6);
  EXPECT_GT(learned, *bad.MatchVariance(0));
  EXPECT_NEAR(std::sqrt(learned), 0.03, 0.006);
  // Axes never informative have nothing to say.
  EXPECT_FALSE(bad.EkfVariance(1, 1e-6).has_value());
  EXPECT_FALSE(bad.MatchVariance(2).has_value());
}

TEST(EkfStepAgreementTest, SaysNothingBeforeTenStepsAndForgetsAnOldPlace) {
  std::mt19937 rng(3);
  EXPECT_FALSE(Learned(0.03, 0.01, 9, &rng).EkfVariance(0, 0.0).has_value());
  EXPECT_TRUE(Learned(0.03, 0.01, 10, &rng).EkfVariance(0, 0.0).has_value());
  // A good EKF for 300 steps, then a bad one for 300: the memory of 100 steps follows.
  EkfStepAgreement agreement = Learned(0.005, 0.02, 300, &rng);
  std::normal_distribution<double> ekf(0.0, 0.05), match(0.0, 0.02);
  for (int i = 0; i < 300; ++i) {
    agreement.Add(Eigen::Vector3d(ekf(rng) - match(rng), 0.0, 0.0),
                  Eigen::Vector3d(0.02 * 0.02, 1.0, 1.0), Eigen::Array3i(1, 0, 0));
  }
  EXPECT_GT(*agreement.EkfVariance(0, 0.0), *agreement.MatchVariance(0));
}

TEST(EkfStepAgreementTest, ItsCheckpointValuesRoundTripAndCorruptOnesAreRefused) {
  std::mt19937 rng(5);
  const EkfStepAgreement learned = Learned(0.01, 0.02, 50, &rng);
  double values[EkfStepAgreement::kValues];
  learned.Values(values);
  const std::optional<EkfStepAgreement> back = EkfStepAgreement::FromValues(values);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(*back->EkfVariance(0, 0.0), *learned.EkfVariance(0, 0.0));
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    double corrupt[EkfStepAgreement::kValues];
    learned.Values(corrupt);
    corrupt[4] = bad;
    EXPECT_FALSE(EkfStepAgreement::FromValues(corrupt).has_value()) << bad;
  }
  double heavy[EkfStepAgreement::kValues];
  learned.Values(heavy);
  heavy[6] = 2 * EkfStepAgreement::kMemorySteps;  // more weight than a window of 100 can hold
  EXPECT_FALSE(EkfStepAgreement::FromValues(heavy).has_value());
}

// A match whose best pose lies on its window's edge found no maximum: the score may still rise
// beyond. Its translation is not used; its heading is.
TEST(LocalMatcherTest, ABestPoseOnTheWindowsEdgeGivesNoTranslation) {
  const std::vector<Wall> room = Box(0.0, 0.0, 8.0, 6.0);
  PointCloud local_map;
  AppendTransformed(testing::ScanPoints(room, Pose2{4.0, 3.0, 0.0}), Pose2{4.0, 3.0, 0.0},
                    &local_map);
  const Pose2 truth{3.0, 3.0, 0.1};
  const PointCloud query = testing::ScanPoints(room, truth);
  const Pose2 prior{3.3, 3.0, 0.1};  // 0.3 m off, with a window of 0.1 m
  const Eigen::Matrix3d prior_covariance = Eigen::Vector3d(0.04, 0.04, 1e-4).asDiagonal();
  LocalMatchSettings settings;
  settings.ignore_edge_translation = true;
  const std::optional<LocalMatchResult> edge =
      MatchLocally(local_map, query, prior, prior_covariance, SearchWindow{0.1, 0.05}, settings);
  ASSERT_TRUE(edge.has_value());
  EXPECT_TRUE(edge->at_window_edge);
  EXPECT_EQ(edge->information.topRows<2>().norm(), 0.0);
  EXPECT_GT(edge->information(2, 2), 0.0);
  EXPECT_NEAR(edge->pose.x, prior.x, 1e-9);
  EXPECT_NEAR(edge->pose.y, prior.y, 1e-9);
  // Fused as any other match (the behaviour before), it pulls the step to the window's edge, here
  // the far one (3.44 m): further from the truth than the prior.
  settings.ignore_edge_translation = false;
  const std::optional<LocalMatchResult> fused =
      MatchLocally(local_map, query, prior, prior_covariance, SearchWindow{0.1, 0.05}, settings);
  ASSERT_TRUE(fused.has_value());
  EXPECT_TRUE(fused->at_window_edge);
  EXPECT_GT(fused->information.topRows<2>().norm(), 0.0);
  EXPECT_GT(std::abs(fused->pose.x - truth.x), std::abs(prior.x - truth.x) + 0.02);
  // A window that holds the truth finds it, inside.
  settings.ignore_edge_translation = true;
  const std::optional<LocalMatchResult> inside =
      MatchLocally(local_map, query, prior, prior_covariance, SearchWindow{0.5, 0.05}, settings);
  ASSERT_TRUE(inside.has_value());
  EXPECT_FALSE(inside->at_window_edge);
  EXPECT_NEAR(inside->matched.x, truth.x, 0.03);
}

// The points of one noisy scan (1 cm of range noise, the LMS200's), as the back end keeps them.
PointCloud NoisyScan(const std::vector<Wall>& walls, const Pose2& pose, std::mt19937* rng) {
  testing::RayCastOptions options;
  options.range_sigma = 0.01;
  options.sensor_range = 12.0;
  const ScanGeometry geometry = testing::Lms200OneDegreeGeometry();
  const LaserScan scan = testing::CastScan(walls, pose, geometry, options, rng);
  PointCloud points;
  for (int i = 0; i < geometry.beam_count; ++i) {
    const double r = scan.ranges[i];
    if (!IsReturn(r, geometry)) continue;
    const double bearing = geometry.angle_min + i * geometry.angle_increment;
    points.emplace_back(static_cast<float>(r * std::cos(bearing)),
                        static_cast<float>(r * std::sin(bearing)));
  }
  return points;
}

// A long room with pillars, driven in 0.6 m steps by a robot whose EKF is exact (the simulator's
// straight walls) and whose odometry is 1 % long with 2 % noise; the session's odometry model
// (5 % and 0.03 rad per metre) is pessimistic, as the simulator's is; the LMS200 at 1 degree with
// 1 cm of range noise, as the simulator's. Returns the RMS translation error of the graph's steps
// from node 20 on (the first steps teach the front end what the EKF is worth).
double ExactEkfStepError(bool learned_prior, unsigned seed) {
  MappingOptions options;
  options.local_learned_prior = learned_prior;
  options.min_loop_travel = 1e4;  // the front end alone: no loop closes
  MappingBackend backend(options);
  std::vector<Wall> walls = Box(0.0, 0.0, 40.0, 3.0);
  for (double x = 3.0; x < 40.0; x += 4.3) {
    for (const Wall& w : Box(x, 0.0, x + 0.3, 0.4)) walls.push_back(w);  // pillars on one side
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<Pose2> truths;
  for (int i = 0; i < 62; ++i) {
    const Pose2 truth{1.0 + 0.6 * i, 1.5 + 0.3 * std::sin(0.4 * i), 0.08 * std::cos(0.5 * i)};
    ScanMotion motion;
    if (i > 0) {
      const Pose2 step = Relative(truths.back(), truth);
      const double d = std::hypot(step.x, step.y);
      motion.increment = Pose2{step.x * (1.01 + 0.02 * noise(rng)), step.y + 0.02 * d * noise(rng),
                               step.theta + 0.005 * noise(rng)};
      const double sxy = 0.002 + 0.05 * d, st = 0.002 + 0.03 * d;
      motion.covariance = Eigen::Vector3d(sxy * sxy, sxy * sxy, st * st).asDiagonal();
    }
    truths.push_back(truth);
    backend.AddScan(i + 1, i, truth, NoisyScan(walls, truth, &rng), motion);
  }
  backend.Flush();
  // The root mean square error of the graph's steps between nodes, from node 20 on.
  const std::vector<NodeView> nodes = backend.Nodes();
  double sum = 0.0;
  int steps = 0;
  for (size_t k = 21; k < nodes.size(); ++k) {
    const Pose2 estimated = Relative(nodes[k - 1].global, nodes[k].global);
    const Pose2 truth = Relative(truths[nodes[k - 1].scan - 1], truths[nodes[k].scan - 1]);
    sum += std::pow(estimated.x - truth.x, 2) + std::pow(estimated.y - truth.y, 2);
    ++steps;
  }
  return std::sqrt(sum / steps);
}

TEST(FrontEndTest, AnEkfTheMatchesShowExactKeepsItsStepsDownALongRoom) {
  // Measured: 9.0-10.6 mm a step fused by the prior alone, 2.6-8.1 mm with the learned prior
  // (means 9.5 and 5.5 mm over the five seeds).
  double fused_sum = 0.0, learned_sum = 0.0;
  for (unsigned seed : {11u, 12u, 13u, 14u, 15u}) {
    const double fused = ExactEkfStepError(false, seed);
    const double learned = ExactEkfStepError(true, seed);
    EXPECT_LT(learned, fused) << "seed " << seed;
    fused_sum += fused;
    learned_sum += learned;
  }
  EXPECT_LT(learned_sum, 0.75 * fused_sum);
}

// An odometry step `step` whose session model is precise (1 cm, 2 mrad).
ScanMotion PreciseOdometry(const Pose2& step) {
  ScanMotion motion;
  motion.increment = step;
  motion.covariance = Eigen::Vector3d(1e-4, 1e-4, 4e-6).asDiagonal();
  return motion;
}

// A room 30 m by 9 m with pillars along both long walls, 4.3 m apart.
std::vector<Wall> RoomWithPillars() {
  std::vector<Wall> walls = Box(0.0, 0.0, 30.0, 9.0);
  for (double x = 3.0; x < 30.0; x += 4.3) {
    for (const Wall& w : Box(x, 0.0, x + 0.3, 0.4)) walls.push_back(w);
    for (const Wall& w : Box(x + 1.5, 8.6, x + 1.9, 9.0)) walls.push_back(w);
  }
  return walls;
}

// A robot drives 0.5 m a step down a room with pillars and, at step 20, turns by `slip` rad
// that neither its odometry nor its EKF sees (wheels slipping on the spot); both carry on from
// the heading they believe. Returns how far the graph's heading change from the first node to the
// last is from the truth's (rad).
double UnseenTurnHeadingError(bool widen, double slip) {
  MappingOptions options;
  options.local_widen_at_heading_edge = widen;
  options.min_loop_travel = 1e4;  // the front end alone
  MappingBackend backend(options);
  const std::vector<Wall> walls = RoomWithPillars();
  std::mt19937 rng(5);
  std::vector<Pose2> truths, believed;
  for (int i = 0; i < 40; ++i) {
    const double heading = i < 20 ? 0.0 : slip;
    const Pose2 truth = i == 0 ? Pose2{1.0, 2.5, 0.0}
                               : Compose(truths.back(), Pose2{0.5, 0.0, heading - truths.back().theta});
    // What the robot believes: every step as the truth's but the slip's turn.
    Pose2 step = i == 0 ? Pose2{} : Relative(truths.back(), truth);
    if (i == 20) step.theta = 0.0;
    const ScanMotion motion = i > 0 ? PreciseOdometry(step) : ScanMotion{};
    believed.push_back(i == 0 ? truth : Compose(believed.back(), step));
    truths.push_back(truth);
    backend.AddScan(i + 1, i, believed.back(), NoisyScan(walls, truth, &rng), motion);
  }
  backend.Flush();
  const std::vector<NodeView> nodes = backend.Nodes();
  const double estimated = nodes.back().global.theta - nodes.front().global.theta;
  const double truth = truths[nodes.back().scan - 1].theta - truths[nodes.front().scan - 1].theta;
  return std::abs(NormalizeAngle(estimated - truth));
}

TEST(FrontEndTest, ATurnTheOdometryDidNotSeeIsFoundInAWiderWindow) {
  // 0.4 rad unseen: the window of the odometry's noise (0.035 rad) holds its best heading on the
  // edge; matched again in the wide window, the turn is found.
  EXPECT_LT(UnseenTurnHeadingError(true, 0.4), 0.03);
  EXPECT_GT(UnseenTurnHeadingError(false, 0.4), 0.2);
  // Nothing unseen: the same either way.
  EXPECT_LT(UnseenTurnHeadingError(true, 0.0), 0.03);
}

// A robot drives 0.5 m a step down a room with pillars with exact odometry; at step 15 its EKF
// jumps `jump` m sideways (a wrong association) and stays there, and that step's scan holds
// nothing the local map can place (a blinded scanner). Returns the graph's step onto that node;
// `odometry_steps` the steps the odometry chained.
Pose2 StepOntoAnUnplacedScan(bool unmatched_odometry, double jump, int* odometry_steps = nullptr) {
  MappingOptions options;
  options.local_unmatched_odometry = unmatched_odometry;
  options.min_loop_travel = 1e4;  // the front end alone
  MappingBackend backend(options);
  const std::vector<Wall> walls = RoomWithPillars();
  std::mt19937 rng(9);
  const auto truth = [](int i) { return Pose2{1.0 + 0.5 * i, 2.5, 0.0}; };
  for (int i = 0; i < 30; ++i) {
    const ScanMotion motion =
        i > 0 ? PreciseOdometry(Relative(truth(i - 1), truth(i))) : ScanMotion{};
    const Pose2 ekf = i < 15 ? truth(i) : Compose(truth(i), Pose2{0.0, jump, 0.0});
    const PointCloud points = i == 15 ? PointCloud{} : NoisyScan(walls, truth(i), &rng);
    backend.AddScan(i + 1, i, ekf, points, motion);
  }
  backend.Flush();
  if (odometry_steps) *odometry_steps = backend.Stats().local_unmatched_odometry;
  const std::vector<NodeView> nodes = backend.Nodes();
  for (size_t k = 1; k < nodes.size(); ++k) {
    if (nodes[k].scan == 16) return Relative(nodes[k - 1].global, nodes[k].global);
  }
  ADD_FAILURE() << "no node for scan 16";
  return Pose2{};
}

TEST(FrontEndTest, AnEkfJumpOnAScanNothingPlacesGivesWayToTheOdometry) {
  // The odometry's noise (1 cm) cannot explain a 3 m step sideways: the odometry's step is kept.
  int odometry_steps = 0;
  const Pose2 kept = StepOntoAnUnplacedScan(true, 3.0, &odometry_steps);
  EXPECT_NEAR(kept.x, 0.5, 0.05);
  EXPECT_NEAR(kept.y, 0.0, 0.05);
  EXPECT_EQ(odometry_steps, 1);
  // Without it the EKF's jump is the step (before).
  EXPECT_NEAR(StepOntoAnUnplacedScan(false, 3.0).y, 3.0, 0.05);
  // An EKF step within the odometry's noise is the EKF's either way.
  EXPECT_NEAR(StepOntoAnUnplacedScan(true, 0.01).y, 0.01, 0.005);
}

TEST(LocalMatcherTest, ABestHeadingOnTheWindowsEdgeIsSaidSo) {
  const std::vector<Wall> room = Box(0.0, 0.0, 8.0, 6.0);
  const Pose2 truth{3.0, 3.0, 0.3};
  PointCloud local_map;
  AppendTransformed(testing::ScanPoints(room, Pose2{4.0, 2.5, 0.0}), Pose2{4.0, 2.5, 0.0}, &local_map);
  const PointCloud query = testing::ScanPoints(room, truth);
  const Pose2 prior{3.0, 3.0, 0.0};
  const Eigen::Matrix3d covariance = Eigen::Vector3d(0.01, 0.01, 0.01).asDiagonal();
  LocalMatchSettings settings;
  settings.min_score = 0.01;  // the narrow window's best scores little: it is still returned
  const auto narrow = MatchLocally(local_map, query, prior, covariance, SearchWindow{0.2, 0.1}, settings);
  ASSERT_TRUE(narrow.has_value());
  EXPECT_TRUE(narrow->at_heading_edge);
  const auto wide = MatchLocally(local_map, query, prior, covariance, SearchWindow{0.2, 0.5}, settings);
  ASSERT_TRUE(wide.has_value());
  EXPECT_FALSE(wide->at_heading_edge);
  EXPECT_NEAR(wide->matched.theta, truth.theta, 0.01);
}

}  // namespace
}  // namespace waymark::laser_slam

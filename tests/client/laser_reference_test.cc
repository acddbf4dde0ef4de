// The laser reference benchmark's pieces (bench/laser/laser_reference.cc): the noisy-odometry
// generator, the relation builder, the keyframe stamp rule, matching keyframes to a raw log, and
// the FLASER writer read back by the CARMEN parser.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "client/datasets/carmen_keyframes.h"
#include "client/datasets/carmen_log.h"
#include "client/eval/odometry_noise.h"
#include "client/eval/relation_builder.h"
#include "client/eval/relations_metric.h"

namespace waymark::cli {
namespace {

// A lap of a 20 m x 10 m rectangle and back along its first side, a keyframe about every 0.5 m,
// turning on the spot at the corners: long enough for loop pairs.
std::vector<StampedPose> Rectangle() {
  std::vector<StampedPose> poses;
  double x = 0, y = 0, theta = 0;
  auto add = [&] { poses.push_back({2.0 * (poses.size() + 1), {x, y, NormalizeAngle(theta)}}); };
  const double sides[] = {20, 10, 20, 10, 20};
  for (double side : sides) {
    for (int step = 0; step < side / 0.5; ++step) {
      x += 0.5 * std::cos(theta);
      y += 0.5 * std::sin(theta);
      add();
    }
    theta += M_PI / 2;
    add();
  }
  return poses;
}

std::vector<Pose2> PosesOf(const std::vector<StampedPose>& stamped) {
  std::vector<Pose2> poses;
  for (const StampedPose& p : stamped) poses.push_back(p.pose);
  return poses;
}

std::vector<StampedPose> Stamped(const std::vector<StampedPose>& like,
                                 const std::vector<Pose2>& poses) {
  std::vector<StampedPose> out;
  for (size_t i = 0; i < poses.size(); ++i) out.push_back({like[i].stamp, poses[i]});
  return out;
}

TEST(OdometryNoise, ZeroStrengthReproducesTheTruthExactly) {
  const std::vector<Pose2> truth = PosesOf(Rectangle());
  const NoisyOdometry odometry =
      GenerateNoisyOdometry(truth, NoiseFor(NoiseStrength::kNone), /*seed=*/7);
  ASSERT_EQ(odometry.poses.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(odometry.poses[i].x, truth[i].x) << i;
    EXPECT_EQ(odometry.poses[i].y, truth[i].y) << i;
    EXPECT_EQ(odometry.poses[i].theta, truth[i].theta) << i;
  }
}

TEST(OdometryNoise, TheSameSeedGivesTheSameOdometryAndAnotherSeedDoesNot) {
  const std::vector<Pose2> truth = PosesOf(Rectangle());
  const OdometryNoise noise = NoiseFor(NoiseStrength::kMedium);
  const NoisyOdometry a = GenerateNoisyOdometry(truth, noise, 42);
  const NoisyOdometry b = GenerateNoisyOdometry(truth, noise, 42);
  const NoisyOdometry c = GenerateNoisyOdometry(truth, noise, 43);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  bool differs_from_c = false;
  for (size_t i = 0; i < a.poses.size(); ++i) {
    EXPECT_EQ(a.poses[i].x, b.poses[i].x);
    EXPECT_EQ(a.poses[i].y, b.poses[i].y);
    EXPECT_EQ(a.poses[i].theta, b.poses[i].theta);
    differs_from_c = differs_from_c || a.poses[i].x != c.poses[i].x;
  }
  EXPECT_TRUE(differs_from_c);
  // The first pose is the truth's: the odometry frame starts where the robot does.
  EXPECT_EQ(a.poses.front().x, truth.front().x);
}

TEST(OdometryNoise, StrongerLevelsDriftMoreAndStartFromTheTruth) {
  const std::vector<StampedPose> truth = Rectangle();
  const std::vector<Relation> relations = BuildRelations(truth).relations;
  double previous = 0;
  for (NoiseStrength s : {NoiseStrength::kLow, NoiseStrength::kMedium, NoiseStrength::kHigh}) {
    const NoisyOdometry odometry = GenerateNoisyOdometry(PosesOf(truth), NoiseFor(s), 1);
    const RelationsResult r = EvaluateRelations(Stamped(truth, odometry.poses), relations);
    EXPECT_EQ(r.relations_used, r.relations);
    EXPECT_GT(r.trans_abs.mean, previous) << NoiseStrengthName(s);
    previous = r.trans_abs.mean;
  }
}

TEST(OdometryNoise, AScaleErrorAloneStretchesAStraightPath) {
  std::vector<Pose2> straight;
  for (int i = 0; i <= 10; ++i) straight.push_back({1.0 * i, 0, 0});
  OdometryNoise noise;
  noise.scale_error = 0.05;
  const NoisyOdometry odometry = GenerateNoisyOdometry(straight, noise, 3);
  EXPECT_NEAR(odometry.poses.back().x, 10.0 * (1 + 0.05 * odometry.scale_sign), 1e-9);
  EXPECT_NEAR(odometry.poses.back().y, 0, 1e-9);
  EXPECT_NEAR(odometry.poses.back().theta, 0, 1e-12);
}

TEST(OdometryNoise, StrengthNames) {
  for (const char* name : {"none", "low", "medium", "high"}) {
    auto parsed = ParseNoiseStrength(name);
    ASSERT_TRUE(parsed.ok()) << name;
    EXPECT_EQ(NoiseStrengthName(*parsed), name);
  }
  EXPECT_FALSE(ParseNoiseStrength("extreme").ok());
}

TEST(RelationBuilder, TheTruthScoresZeroAndEveryKindIsThere) {
  const std::vector<StampedPose> truth = Rectangle();
  const BuiltRelations built = BuildRelations(truth);
  const int n = static_cast<int>(truth.size());
  EXPECT_EQ(built.sequential, (n - 1) + (n - 3) + (n - 10));
  EXPECT_GT(built.loops, 0);  // the last side runs over the first
  EXPECT_EQ(built.relations.size(), static_cast<size_t>(built.sequential + built.loops));
  const RelationsResult r = EvaluateRelations(truth, built.relations);
  EXPECT_EQ(r.relations_used, r.relations);
  EXPECT_NEAR(r.trans_abs.mean, 0, 1e-9);
  EXPECT_NEAR(r.rot_abs_deg.mean, 0, 1e-7);
  // Loop pairs are revisits: close in space, far apart in the sequence.
  for (size_t k = built.sequential; k < built.relations.size(); ++k) {
    const Relation& rel = built.relations[k];
    EXPECT_LE(std::hypot(rel.delta.x, rel.delta.y), 2.0);
    EXPECT_GE(rel.t2 - rel.t1, 2.0 * 20);
  }
}

TEST(RelationBuilder, IsDeterministicAndCapsLoops) {
  const std::vector<StampedPose> truth = Rectangle();
  RelationBuilderOptions options;
  options.max_loop_relations = 3;
  const BuiltRelations a = BuildRelations(truth, options);
  const BuiltRelations b = BuildRelations(truth, options);
  EXPECT_EQ(a.loops, 3);
  EXPECT_GT(a.loop_candidates, 3);
  EXPECT_EQ(FormatRelations(a.relations), FormatRelations(b.relations));
}

TEST(RelationBuilder, FormattedRelationsParseBack) {
  const std::vector<StampedPose> truth = Rectangle();
  const BuiltRelations built = BuildRelations(truth);
  absl::StatusOr<std::vector<Relation>> parsed =
      ParseRelations(FormatRelations(built.relations, {"made by a test"}));
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  ASSERT_EQ(parsed->size(), built.relations.size());
  const RelationsResult r = EvaluateRelations(truth, *parsed);
  EXPECT_EQ(r.relations_used, r.relations);
  EXPECT_LT(r.trans_abs_max, 2e-6);
}

}  // namespace
}  // namespace waymark::cli

namespace waymark::adapters {
namespace {

TEST(KeyframeStamps, IncreasingStampsAreKept) {
  const KeyframeStamps s = ChooseKeyframeStamps({10.0, 12.5, 13.0});
  EXPECT_EQ(s.source, KeyframeStampSource::kLog);
  EXPECT_EQ(s.stamps, (std::vector<double>{10.0, 12.5, 13.0}));
}

TEST(KeyframeStamps, AFewStepsBackAreRepaired) {
  std::vector<double> stamps;
  for (int i = 0; i < 200; ++i) stamps.push_back(100.0 + 3.0 * i);
  stamps[50] = stamps[49] - 0.1;  // Intel-like: a keyframe that kept an out-of-order stamp
  const KeyframeStamps s = ChooseKeyframeStamps(stamps);
  EXPECT_EQ(s.source, KeyframeStampSource::kRepaired);
  EXPECT_EQ(s.repaired, 1);
  EXPECT_DOUBLE_EQ(s.stamps[50], stamps[49] + kRepairStepS);
  EXPECT_EQ(s.stamps[51], stamps[51]);
}

TEST(KeyframeStamps, ZeroOrRepeatedStampsAreSynthesized) {
  for (const std::vector<double>& stamps :
       {std::vector<double>(5, 0.0), std::vector<double>{1.13486e9, 1.13486e9, 1.13487e9},
        std::vector<double>{-0.4, -0.9, 4.29497e9, 4.29497e9}}) {
    const KeyframeStamps s = ChooseKeyframeStamps(stamps);
    EXPECT_EQ(s.source, KeyframeStampSource::kSynthesized);
    ASSERT_EQ(s.stamps.size(), stamps.size());
    for (size_t i = 0; i < stamps.size(); ++i) {
      EXPECT_DOUBLE_EQ(s.stamps[i], kSynthesizedKeyframeIntervalS * (i + 1));
    }
  }
}

CarmenLaser Scan(std::vector<float> ranges, double stamp, double x) {
  CarmenLaser laser;
  laser.stamp = stamp;
  laser.ranges = std::move(ranges);
  laser.laser_pose = {x, 0.5, -0.25};
  laser.odom_pose = laser.laser_pose;
  return laser;
}

TEST(RawMatch, KeyframesAreFoundByTheirRangesInOrder) {
  // Raw scans 0..4; scan 1's ranges repeat at 3 (a robot standing still).
  const std::vector<CarmenLaser> raw = {
      Scan({1.00f, 2.00f}, 1000.0, 0), Scan({1.10f, 2.10f}, 1000.2, 0),
      Scan({1.20f, 2.20f}, 1000.4, 0), Scan({1.10f, 2.10f}, 1000.6, 0),
      Scan({1.30f, 2.30f}, 1000.8, 0)};
  // Keyframes printed with fewer digits and logger-relative stamps (offset 990 s); the second one
  // repeats the first's ranges, so it must take the later copy; the last is in no raw scan.
  const std::vector<CarmenLaser> keyframes = {
      Scan({1.1f, 2.1f}, 10.2, 0), Scan({1.1f, 2.1f}, 10.6, 0), Scan({1.3f, 2.3f}, 10.8, 0),
      Scan({9.0f, 9.0f}, 11.0, 0)};
  const RawMatch match = MatchKeyframesToRaw(keyframes, raw);
  EXPECT_EQ(match.raw_index, (std::vector<int>{1, 3, 4, -1}));
  EXPECT_EQ(match.matched, 3);
  EXPECT_EQ(match.ambiguous, 1);
  EXPECT_NEAR(match.stamp_offset_median, 990.0, 1e-9);
  EXPECT_LT(match.stamp_offset_spread, 1e-6);
  EXPECT_EQ(match.stamps_equal_within_1ms, 0);
}

TEST(FlaserWriter, ALineReadsBackToTheSameScan) {
  CarmenLaser laser = Scan({4.1f, 81.91f, 0.27f}, 1134864629.895182, 576.536523);
  laser.odom_pose = {1.5, -2.25, 3.0};
  const std::string line = FormatFlaserLine(laser, "noisy");
  EXPECT_EQ(line.substr(0, 27), "FLASER 3 4.1 81.91 0.27 576");
  CarmenRecord record;
  absl::StatusOr<bool> parsed = ParseCarmenLine(line, 1, &record);
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  ASSERT_TRUE(*parsed);
  ASSERT_EQ(record.type, CarmenRecord::Type::kLaser);
  const CarmenLaser& back = record.laser;
  EXPECT_EQ(back.ranges, laser.ranges);
  EXPECT_NEAR(back.stamp, laser.stamp, 1e-6);
  EXPECT_NEAR(back.laser_pose.x, 576.536523, 1e-6);
  EXPECT_NEAR(back.laser_pose.theta, -0.25, 1e-6);
  EXPECT_NEAR(back.odom_pose.y, -2.25, 1e-6);
  EXPECT_NEAR(back.odom_pose.theta, 3.0, 1e-6);
}

}  // namespace
}  // namespace waymark::adapters

// `waymark eval ate`: the TUM and KITTI pose readers (pose_file.h) including malformed input, the
// command end to end on temporary files, and a real-data check on the TUM fr3 ground truth in
// ../shared/data/vslam (skipped when absent).
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "client/datasets/pose_file.h"
#include "client/eval/trajectory_metrics.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

CliResult Ate(std::vector<std::string> args) {
  args.insert(args.begin(), {"eval", "ate"});
  return RunWaymark("127.0.0.1:1", std::move(args));  // needs no server
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

std::string TumText(const std::vector<StampedPose3>& poses) {
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose3& p : poses) {
    const Eigen::Quaterniond q(p.rotation);
    text += fmt::format("{:.6f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f}\n", p.stamp,
                        p.translation.x(), p.translation.y(), p.translation.z(), q.x(), q.y(),
                        q.z(), q.w());
  }
  return text;
}

std::string KittiText(const std::vector<StampedPose3>& poses) {
  std::string text;
  for (const StampedPose3& p : poses) {
    const Eigen::Matrix3d& r = p.rotation;
    const Eigen::Vector3d& t = p.translation;
    text += fmt::format(
        "{:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} "
        "{:.9e} {:.9e}\n",
        r(0, 0), r(0, 1), r(0, 2), t.x(), r(1, 0), r(1, 1), r(1, 2), t.y(), r(2, 0), r(2, 1),
        r(2, 2), t.z());
  }
  return text;
}

std::vector<StampedPose3> Path(int n, double t0 = 100.0, double dt = 0.1) {
  std::vector<StampedPose3> poses;
  for (int i = 0; i < n; ++i) {
    StampedPose3 p;
    p.stamp = t0 + dt * i;
    p.translation = Eigen::Vector3d(0.2 * i, std::sin(0.3 * i), 0.5 * std::cos(0.1 * i));
    p.rotation = (Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(0.2 * std::sin(0.2 * i), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    poses.push_back(p);
  }
  return poses;
}

std::vector<StampedPose3> Moved(std::vector<StampedPose3> poses, double scale = 1.0) {
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(3, -1, 2);
  for (StampedPose3& p : poses) {
    p.translation = scale * r * p.translation + t;
    p.rotation = r * p.rotation;
  }
  return poses;
}

// --- readers ---

TEST(PoseFile, TumWithCommentsCommasAndNearUnitQuaternion) {
  const std::string text =
      "# ground truth\n\n"
      "1.5 1 2 3 0 0 0 1\n"
      "  2.5,1,2,3,0,0,0.7071,0.7071  \n"
      "3.5 0 0 0 0 0 0 1.05\n";  // norm 1.05: normalised
  auto file = ParsePoseText(text);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->format, PoseFormat::kTum);
  ASSERT_EQ(file->poses.size(), 3u);
  EXPECT_DOUBLE_EQ(file->poses[0].stamp, 1.5);
  EXPECT_TRUE(file->poses[0].translation.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(file->poses[1].rotation.isApprox(
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-4));
  EXPECT_TRUE(file->poses[2].rotation.isIdentity(1e-12));
}

TEST(PoseFile, TumMalformedLinesNameTheLine) {
  auto status = [](const std::string& text) { return ParsePoseText(text).status(); };
  absl::Status s = status("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 0\n");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("line 2"));
  EXPECT_THAT(s.message(), HasSubstr("zero"));

  s = status("1 0 0 0 0 0 0 1\n# c\n2 nan 0 0 0 0 0 1\n");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("line 3"));
  EXPECT_THAT(s.message(), HasSubstr("not a finite number"));

  s = status("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n");  // 7 fields
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("line 2"));

  s = status("1 0 0 0 1 2 3 4\n");  // norm 5.5: columns in the wrong order?
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("far from 1"));

  s = status("1 0 0 0 0 0 1\n");  // 7 fields: neither format
  EXPECT_THAT(s.message(), HasSubstr("expected 8 (TUM"));
  EXPECT_EQ(status("# nothing\n\n").code(), absl::StatusCode::kInvalidArgument);
}

// Without times.txt, pose i is at 0.1 * i s: KITTI's 10 Hz, the stamps `vo run` gives the frames.
TEST(PoseFile, KittiStampsAreTenHertzOrFromTimes) {
  const auto path = Path(4);
  auto file = ParsePoseText(KittiText(path));
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->format, PoseFormat::kKitti);
  ASSERT_EQ(file->poses.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(file->poses[i].stamp, 0.1 * i);
    EXPECT_TRUE(file->poses[i].translation.isApprox(path[i].translation, 1e-8));
    EXPECT_TRUE(file->poses[i].rotation.isApprox(path[i].rotation, 1e-8));
  }
  auto stamps = ParseStampList("0.000000e+00\n1.036231e-01\n2.072477e-01\n3.108680e-01\n");
  ASSERT_TRUE(stamps.ok()) << stamps.status();
  PoseFileOptions options;
  options.kitti_stamps = *stamps;
  file = ParsePoseText(KittiText(path), options);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_DOUBLE_EQ(file->poses[3].stamp, 0.310868);

  options.kitti_stamps->pop_back();
  EXPECT_THAT(ParsePoseText(KittiText(path), options).status().message(),
              HasSubstr("4 KITTI poses but 3 time stamps"));
}

TEST(PoseFile, KittiMalformed) {
  // Line 2: not a rotation (a scaled one).
  const std::string bad = "1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 2 0 0 0 0 2 0\n";
  absl::Status s = ParsePoseText(bad).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("line 2"));
  EXPECT_THAT(s.message(), HasSubstr("not a rotation"));
  // A reflection is not a rotation either.
  s = ParsePoseText("-1 0 0 0 0 1 0 0 0 0 1 0\n").status();
  EXPECT_THAT(s.message(), HasSubstr("not a rotation"));
  // 11 numbers on line 2.
  s = ParsePoseText("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n").status();
  EXPECT_THAT(s.message(), HasSubstr("line 2"));
  // Forcing TUM on a KITTI file.
  PoseFileOptions tum;
  tum.format = PoseFormat::kTum;
  s = ParsePoseText("1 0 0 0 0 1 0 0 0 0 1 0\n", tum).status();
  EXPECT_THAT(s.message(), HasSubstr("expected 8 fields"));
}

TEST(PoseFile, ReadErrorsNameTheFile) {
  ScopedTempDir dir;
  const auto path = dir.Make("bad.txt");
  WriteText(path, "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 x\n");
  absl::Status s = ReadPoseFile(path).status();
  EXPECT_THAT(s.message(), HasSubstr(path.string()));
  EXPECT_THAT(s.message(), HasSubstr("line 2"));
  EXPECT_EQ(ReadPoseFile(dir.path() / "missing.txt").status().code(), absl::StatusCode::kNotFound);
}

// --- command line ---

TEST(EvalAteCommand, RigidCopyGivesZeroAteAsJson) {
  ScopedTempDir dir;
  const auto gt = Path(60);
  auto est = Moved(gt);
  for (size_t i = 0; i < est.size(); ++i) est[i].stamp += (i % 2 ? 0.004 : -0.003);  // jitter
  WriteText(dir.Make("gt.txt"), TumText(gt));
  WriteText(dir.Make("est.txt"), TumText(est));
  CliResult r =
      Ate({(dir.path() / "est.txt").string(), (dir.path() / "gt.txt").string(), "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto json = r.Json();
  EXPECT_EQ(json["poses_matched"], 60);
  EXPECT_EQ(json["poses_estimated"], 60);
  EXPECT_EQ(json["poses_groundtruth"], 60);
  EXPECT_LT(json["ate_rmse"].get<double>(), 1e-6);
  EXPECT_LT(json["ate_mean"].get<double>(), 1e-6);
  EXPECT_LT(json["ate_std"].get<double>(), 1e-6);
  EXPECT_LT(json["ate_median"].get<double>(), 1e-6);
  EXPECT_LT(json["ate_max"].get<double>(), 1e-6);
  EXPECT_LT(json["rpe_trans_rmse"].get<double>(), 1e-6);
  EXPECT_LT(json["rpe_rot_rmse_deg"].get<double>(), 1e-4);
  EXPECT_DOUBLE_EQ(json["scale"].get<double>(), 1.0);
  EXPECT_EQ(json["trajectory_format"], "tum");

  r = Ate({(dir.path() / "est.txt").string(), (dir.path() / "gt.txt").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("60 poses matched"));
  EXPECT_THAT(r.out, HasSubstr("ATE (m)"));
  EXPECT_THAT(r.out, HasSubstr("RPE rot (deg, delta 1)"));
}

TEST(EvalAteCommand, ScaleFlagAndKittiWithTimes) {
  ScopedTempDir dir;
  const auto gt = Path(40, 0.0, 0.1);
  const auto est = Moved(gt, 0.5);
  WriteText(dir.Make("gt.txt"), KittiText(gt));
  WriteText(dir.Make("est.txt"), KittiText(est));
  std::string times;
  for (int i = 0; i < 40; ++i) times += fmt::format("{:.6e}\n", 0.1 * i);
  WriteText(dir.Make("times.txt"), times);
  const std::string e = (dir.path() / "est.txt").string();
  const std::string g = (dir.path() / "gt.txt").string();

  CliResult r = Ate({e, g, "--json", "--scale"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["trajectory_format"], "kitti");
  EXPECT_EQ(r.Json()["poses_matched"], 40);
  EXPECT_NEAR(r.Json()["scale"].get<double>(), 2.0, 1e-6);
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-6);
  EXPECT_LT(r.Json()["rpe_trans_rmse"].get<double>(), 1e-6);

  r = Ate({e, g, "--json"});  // rigid only: the half-size copy does not fit
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(r.Json()["ate_rmse"].get<double>(), 0.1);

  // With the times file (10 Hz) the default 0.02 s window still matches every pose; with a TUM
  // estimate at the same stamps the formats mix.
  WriteText(dir.Make("est_tum.txt"), TumText(Moved(gt)));
  r = Ate({(dir.path() / "est_tum.txt").string(), g, "--times", (dir.path() / "times.txt").string(),
           "--json", "--delta", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 40);
  EXPECT_EQ(r.Json()["rpe_pairs"], 38);
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-6);

  r = Ate({e, g, "--format", "tum"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(r.err, HasSubstr("expected 8 fields"));
}

// What `vo run` writes for a KITTI sequence without times.txt (a TUM file, frames 0.1 s apart)
// against the sequence's poses.txt: every pose matches, and no warning.
TEST(EvalAteCommand, VoTrajectoryOfAKittiSequenceMatchesItsPosesWithoutTimes) {
  ScopedTempDir dir;
  const auto gt = Path(51, 0.0, 0.1);
  WriteText(dir.Make("poses.txt"), KittiText(gt));
  WriteText(dir.Make("trajectory.txt"), TumText(Moved(gt)));
  CliResult r = Ate({(dir.path() / "trajectory.txt").string(), (dir.path() / "poses.txt").string(),
                     "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 51);
  EXPECT_TRUE(r.Json()["match_warning"].is_null());
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-6);
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("warning")));
}

// Trajectories on different clocks: the few poses that happen to match give an ATE, with a
// warning on stderr and in --json that names both stamp spans.
TEST(EvalAteCommand, FewMatchedPosesWarnOnStderrAndInJson) {
  ScopedTempDir dir;
  const auto gt = Path(51, 0.0, 0.1);
  auto est = Moved(gt);
  for (size_t i = 0; i < est.size(); ++i) est[i].stamp = static_cast<double>(i);  // 1 s apart
  WriteText(dir.Make("gt.txt"), TumText(gt));
  WriteText(dir.Make("est.txt"), TumText(est));
  const std::string e = (dir.path() / "est.txt").string();
  const std::string g = (dir.path() / "gt.txt").string();

  CliResult r = Ate({e, g});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("6 poses matched"));
  EXPECT_THAT(r.err, HasSubstr("warning: only 6 of 51 poses matched"));
  EXPECT_THAT(r.err, HasSubstr("estimate has 51 poses, stamps 0.000000 .. 50.000000"));
  EXPECT_THAT(r.err, HasSubstr("ground truth has 51 poses, stamps 0.000000 .. 5.000000"));

  r = Ate({e, g, "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 6);
  ASSERT_TRUE(r.Json()["match_warning"].is_string());
  EXPECT_THAT(r.Json()["match_warning"].get<std::string>(), HasSubstr("only 6 of 51"));
  EXPECT_THAT(r.err, HasSubstr("warning: only 6 of 51"));
}

TEST(EvalAteCommand, ErrorsNameFileAndLineOrTheMatchCount) {
  ScopedTempDir dir;
  const auto gt = Path(30);
  WriteText(dir.Make("gt.txt"), TumText(gt));
  WriteText(dir.Make("bad.txt"), "100 0 0 0 0 0 0 1\n100.1 0 0 0 0 0 0 0\n");
  CliResult r = Ate({(dir.path() / "bad.txt").string(), (dir.path() / "gt.txt").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(r.err, HasSubstr("bad.txt: line 2"));

  auto late = gt;
  for (StampedPose3& p : late) p.stamp += 1000;
  WriteText(dir.Make("late.txt"), TumText(late));
  r = Ate({(dir.path() / "late.txt").string(), (dir.path() / "gt.txt").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("FAILED_PRECONDITION"));
  EXPECT_THAT(r.err, HasSubstr("only 0 poses matched"));
  EXPECT_THAT(r.err, HasSubstr("1100.000000 .. 1102.900000"));
  EXPECT_THAT(r.err, HasSubstr("100.000000 .. 102.900000"));

  r = Ate({(dir.path() / "gt.txt").string(), (dir.path() / "gt.txt").string(), "--plot",
           (dir.path() / "x.pdf").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr(".svg or .png"));

  r = Ate({(dir.path() / "gt.txt").string(), (dir.path() / "gt.txt").string(), "--times",
           (dir.path() / "gt.txt").string()});
  EXPECT_EQ(r.code, 1);  // times.txt has one column
  EXPECT_THAT(r.err, HasSubstr("line 2"));
}

TEST(EvalAteCommand, PlotWritesSvgAndPng) {
  ScopedTempDir dir;
  const auto gt = Path(30);
  WriteText(dir.Make("gt.txt"), TumText(gt));
  WriteText(dir.Make("est.txt"), TumText(Moved(gt)));
  const std::string svg = (dir.path() / "top.svg").string();
  CliResult r =
      Ate({(dir.path() / "est.txt").string(), (dir.path() / "gt.txt").string(), "--plot", svg});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(ReadAll(svg), HasSubstr("<svg"));
  EXPECT_THAT(ReadAll(svg), HasSubstr("ground truth"));
  // Both paths marked where they start and end; no legend for map segments it does not have.
  EXPECT_THAT(ReadAll(svg), HasSubstr("class=\"start\""));
  EXPECT_THAT(ReadAll(svg), HasSubstr("<polygon class=\"end\""));
  EXPECT_THAT(ReadAll(svg), ::testing::Not(HasSubstr("both endpoints real")));
  const std::string png = (dir.path() / "top.png").string();
  r = Ate({(dir.path() / "est.txt").string(), (dir.path() / "gt.txt").string(), "--plot", png});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
}

// --- real data: TUM fr3 ground truth and KITTI 06 poses, read in place from ../shared ---

std::filesystem::path VslamDir() {
  return std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "vslam";
}

TEST(EvalAteRealData, TumGroundTruthAgainstItselfAndAMovedCopy) {
  const auto gt_path = VslamDir() / "tum_fr3_dynamic_groundtruth/fr3_walking_xyz/groundtruth.txt";
  if (!std::filesystem::exists(gt_path)) {
    GTEST_SKIP() << gt_path << " is absent (../shared/data/vslam): real-data check skipped";
  }
  CliResult r = Ate({gt_path.string(), gt_path.string(), "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 2884);
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-9);
  EXPECT_LT(r.Json()["rpe_trans_rmse"].get<double>(), 1e-9);

  // A copy moved by a known rigid transform, scaled by 2 and shifted by 1 ms in time
  // (the ground truth has poses as close as 2.5 ms, so 1 ms keeps every pose nearest its twin).
  auto gt = ReadPoseFile(gt_path);
  ASSERT_TRUE(gt.ok()) << gt.status();
  auto moved = Moved(gt->poses, 2.0);
  for (StampedPose3& p : moved) p.stamp += 0.001;
  ScopedTempDir dir;
  WriteText(dir.Make("moved.txt"), TumText(moved));
  r = Ate({(dir.path() / "moved.txt").string(), gt_path.string(), "--json", "--scale"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 2884);
  EXPECT_NEAR(r.Json()["scale"].get<double>(), 0.5, 1e-6);
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-5);
  EXPECT_LT(r.Json()["rpe_rot_rmse_deg"].get<double>(), 1e-3);

  // A known offset the alignment cannot absorb: one pose displaced by 1 m along x out of 2884.
  // Its displacement moves the fit by a little, so compare with the closed form: the optimal
  // rigid fit of a single outlier of size d among n poses leaves ATE RMSE close to
  // d * sqrt((n - 1) / n) / sqrt(n) (translation absorbs d / n of it).
  auto offset = gt->poses;
  offset[1000].translation.x() += 1.0;
  WriteText(dir.Make("offset.txt"), TumText(offset));
  r = Ate({(dir.path() / "offset.txt").string(), gt_path.string(), "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const double n = 2884;
  EXPECT_NEAR(r.Json()["ate_max"].get<double>(), 1.0, 0.01);
  EXPECT_NEAR(r.Json()["ate_rmse"].get<double>(), std::sqrt((n - 1) / n) / std::sqrt(n), 2e-3);
}

TEST(EvalAteRealData, KittiPosesAgainstThemselves) {
  const auto poses = VslamDir() / "kitti_odom06_frames000-050/poses.txt";
  if (!std::filesystem::exists(poses)) {
    GTEST_SKIP() << poses << " is absent (../shared/data/vslam): real-data check skipped";
  }
  CliResult r = Ate({poses.string(), poses.string(), "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses_matched"], 51);
  EXPECT_EQ(r.Json()["trajectory_format"], "kitti");
  EXPECT_LT(r.Json()["ate_rmse"].get<double>(), 1e-9);
}

}  // namespace
}  // namespace waymark::cli

// `waymark vo run` against the real server: the first 30 frames of the Bonn RGB-D crowd window in
// ../shared/data/vslam (skipped when absent), RGB-D, no detector. Every frame is answered and
// written to trajectory.txt, the summary carries the ATE against the sequence's ground truth, and
// the pictures are there.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "client/datasets/pose_file.h"
#include "tests/client/test_util.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

namespace fs = std::filesystem;

TEST(VoRunTest, BonnFirstThirtyFramesRgbd) {
  const fs::path sequence =
      fs::path(WAYMARK_SHARED_DIR) / "data/vslam/bonn_rgbd_crowd_frames270-409";
  if (!fs::exists(sequence)) GTEST_SKIP() << sequence << " not present";
  const std::string dir = testing::MakeTempDir("vo-run");
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db");
  ASSERT_TRUE(server.ok()) << server.status();

  const fs::path out = fs::path(dir) / "out";
  const testing::CliResult run = testing::RunWaymark(
      (*server)->address(),
      {"--json", "vo", "run", sequence.string(), "--depth", "--detector", "none", "--camera",
       "bonn", "--max-frames", "30", "--out", out.string()});
  ASSERT_EQ(run.code, 0) << run.err << run.out << (*server)->Log();
  const nlohmann::json summary = run.Json();
  EXPECT_EQ(summary["frames"], 30);
  EXPECT_EQ(summary["processed"], 30) << run.err;
  EXPECT_EQ(summary["rejected"], 0);
  ASSERT_TRUE(summary.contains("ate_rmse")) << summary.dump(2);
  const double ate = summary["ate_rmse"].get<double>();
  EXPECT_TRUE(std::isfinite(ate));
  EXPECT_GE(ate, 0);
  EXPECT_EQ(summary["poses_matched"], 30);   // ground truth at 30 Hz covers every frame
  EXPECT_EQ(summary["alignment"], "SE(3)");  // RGB-D: metric, no scale

  // summary.json on disk is what --json printed.
  std::ifstream file(out / "summary.json");
  EXPECT_EQ(nlohmann::json::parse(file), summary);

  // One TUM line per frame, read back with the `eval ate` reader, stamps those of rgb.txt.
  absl::StatusOr<cli::PoseFile> trajectory = cli::ReadPoseFile(out / "trajectory.txt");
  ASSERT_TRUE(trajectory.ok()) << trajectory.status();
  ASSERT_EQ(trajectory->poses.size(), 30u);
  EXPECT_NEAR(trajectory->poses.front().stamp, 1548339828.92438, 1e-6);
  EXPECT_TRUE(fs::exists(out / "trajectory.svg"));

  // Frames 0 and 25 are sampled; each picture has the frame's size.
  for (const char* name : {"000000.png", "000025.png"}) {
    const cv::Mat picture = cv::imread((out / "frames" / name).string());
    ASSERT_FALSE(picture.empty()) << name;
    EXPECT_EQ(picture.cols, 640);
    EXPECT_EQ(picture.rows, 480);
  }

  EXPECT_EQ((*server)->Stop(SIGTERM), 0);
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace waymark

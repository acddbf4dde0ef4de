#include "tests/visual_slam/sequence_fixture.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "client/common/read_file.h"
#include "client/eval/trajectory_metrics.h"
#include "server/visual_slam/detectors/detector_factory.h"

namespace waymark::visual_slam::testing {
namespace {

const std::string kVslam = std::string(WAYMARK_SHARED_DIR) + "/data/vslam/";

std::optional<cli::ImageSequence> ReadShared(const std::string& name) {
  if (!std::filesystem::exists(kVslam + name)) return std::nullopt;
  absl::StatusOr<cli::ImageSequence> sequence = cli::ReadImageSequence(kVslam + name);
  EXPECT_TRUE(sequence.ok()) << sequence.status();
  return sequence.ok() ? std::optional<cli::ImageSequence>(*sequence) : std::nullopt;
}

}  // namespace

cv::Mat RandomTexture(int width, int height, unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat noise(height / 4, width / 4, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::Mat texture;
  cv::resize(noise, texture, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
  return texture;
}

CameraModel SyntheticCamera() {
  CameraModel camera;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  return camera;
}

std::optional<cli::ImageSequence> BonnSequence() {
  return ReadShared("bonn_rgbd_crowd_frames270-409");
}

std::optional<cli::ImageSequence> KittiSequence() {
  return ReadShared("kitti_odom06_frames000-050");
}

CameraModel SequenceCamera(const cli::ImageSequence& sequence, const std::string& preset) {
  cli::CameraIntrinsics intrinsics;
  if (sequence.intrinsics) {
    intrinsics = *sequence.intrinsics;
  } else {
    absl::StatusOr<cli::CameraIntrinsics> named = cli::CameraPreset(preset);
    EXPECT_TRUE(named.ok()) << named.status();
    if (named.ok()) intrinsics = *named;
  }
  CameraModel camera;
  camera.fx = intrinsics.fx;
  camera.fy = intrinsics.fy;
  camera.cx = intrinsics.cx;
  camera.cy = intrinsics.cy;
  camera.distortion = intrinsics.distortion;
  const cv::Mat first = cv::imread(sequence.frames.at(0).image.string(), cv::IMREAD_UNCHANGED);
  camera.width = first.cols;
  camera.height = first.rows;
  return camera;
}

std::unique_ptr<ObjectDetector> SharedYolo() {
  const std::filesystem::path dir =
      std::filesystem::path(WAYMARK_SHARED_DIR) / "models/yolo-fastest-1.1-coco";
  if (!std::filesystem::exists(dir)) return nullptr;
  DetectorChoice choice;
  choice.kind = DetectorChoice::kYolo;
  absl::StatusOr<std::string> cfg = cli::ReadFileBytes(dir / "yolo-fastest-1.1-xl.cfg");
  absl::StatusOr<std::string> weights = cli::ReadFileBytes(dir / "yolo-fastest-1.1-xl.weights");
  EXPECT_TRUE(cfg.ok() && weights.ok());
  if (!cfg.ok() || !weights.ok()) return nullptr;
  choice.yolo.cfg = *cfg;
  choice.yolo.weights = *weights;
  absl::StatusOr<std::unique_ptr<ObjectDetector>> detector = MakeDetector(choice);
  EXPECT_TRUE(detector.ok()) << detector.status();
  return detector.ok() ? *std::move(detector) : nullptr;
}

RunSummary RunAndEvaluate(VisualOdometry& odometry, const cli::ImageSequence& sequence,
                          bool with_depth, bool with_scale) {
  RunSummary summary;
  const bool debug = std::getenv("WAYMARK_VO_DEBUG") != nullptr;
  for (size_t i = 0; i < sequence.frames.size(); ++i) {
    const cli::SequenceFrame& frame = sequence.frames[i];
    FrameInput input;
    input.stamp = frame.stamp;
    input.image = cv::imread(frame.image.string(), cv::IMREAD_COLOR);
    if (with_depth && frame.depth) {
      input.depth = cv::imread(frame.depth->string(), cv::IMREAD_UNCHANGED);
    }
    absl::StatusOr<FrameResult> result = odometry.ProcessFrame(input);
    EXPECT_TRUE(result.ok()) << frame.image << ": " << result.status();
    if (!result.ok()) continue;
    ++summary.frames;
    if (result->state == TrackingState::kLost) ++summary.lost;
    summary.dynamic += result->counts.dynamic;
    summary.potentially_dynamic += result->counts.potentially_dynamic;
    if (debug) {
      const FeatureCounts& c = result->counts;
      std::printf(
          "%3zu %s kf=%d total=%d pdyn=%d matched=%d dyn=%d tracked=%d mapped=%d "
          "t=(%.3f %.3f %.3f) rot=%.2f ms=%.1f\n",
          i, TrackingStateName(result->state), result->keyframe, c.total, c.potentially_dynamic,
          c.matched, c.dynamic, c.tracked, c.mapped, result->pose.t.x(), result->pose.t.y(),
          result->pose.t.z(), Eigen::AngleAxisd(result->pose.R).angle() * 57.2958,
          result->timings.total_ms);
    }
  }
  absl::StatusOr<std::vector<cli::StampedPose3>> groundtruth =
      cli::ReadSequenceGroundTruth(sequence);
  EXPECT_TRUE(groundtruth.ok()) << groundtruth.status();
  if (!groundtruth.ok()) return summary;
  std::vector<cli::StampedPose3> estimate;
  for (const TimedPose& pose : odometry.trajectory()) {
    estimate.push_back({pose.stamp, pose.pose.R, pose.pose.t});
  }
  cli::TrajectoryOptions options;
  options.with_scale = with_scale;
  absl::StatusOr<cli::TrajectoryEvaluation> evaluation =
      cli::EvaluateTrajectory(estimate, *groundtruth, options);
  EXPECT_TRUE(evaluation.ok()) << evaluation.status();
  if (evaluation.ok()) summary.ate_rmse = evaluation->ate.rmse;
  return summary;
}

}  // namespace waymark::visual_slam::testing

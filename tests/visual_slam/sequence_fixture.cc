#include "tests/visual_slam/sequence_fixture.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include "server/visual_slam/detector_factory.h"

namespace waymark::visual_slam::testing {
namespace {

const std::string kVslam = std::string(WAYMARK_SHARED_DIR) + "/data/vslam/";
const std::string kBonn = kVslam + "bonn_rgbd_crowd_frames270-409/";
const std::string kKitti = kVslam + "kitti_odom06_frames000-050/";

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

std::vector<RealFrame> BonnFrames() {
  std::vector<RealFrame> frames;
  std::ifstream in(kBonn + "associations.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    RealFrame frame;
    double depth_stamp = 0;
    std::string rgb, depth;
    if (fields >> frame.stamp >> rgb >> depth_stamp >> depth) {
      frame.image_path = kBonn + rgb;
      frame.depth_path = kBonn + depth;
      frames.push_back(frame);
    }
  }
  return frames;
}

CameraModel BonnCamera() {
  // Bonn RGB-D Dynamic dataset page (../shared/data/vslam/SOURCES.md).
  CameraModel camera;
  camera.fx = 542.822841;
  camera.fy = 542.576870;
  camera.cx = 315.593520;
  camera.cy = 237.756098;
  camera.distortion = {0.039903, -0.099343, -0.000730, -0.000144, 0.0};
  camera.width = 640;
  camera.height = 480;
  return camera;
}

std::vector<RealFrame> KittiFrames() {
  std::vector<RealFrame> frames;
  for (int i = 0; i <= 50; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "image_0/%06d.png", i);
    if (!std::filesystem::exists(kKitti + name)) break;
    frames.push_back({0.1 * i, kKitti + name, ""});
  }
  return frames;
}

CameraModel KittiCamera() {
  CameraModel camera;  // calib.txt P0
  camera.fx = camera.fy = 707.0912;
  camera.cx = 601.8873;
  camera.cy = 183.1104;
  camera.width = 1226;
  camera.height = 370;
  return camera;
}

std::unique_ptr<ObjectDetector> SharedYolo() {
  const std::string dir = std::string(WAYMARK_SHARED_DIR) + "/models/yolo-fastest-1.1-coco/";
  auto slurp = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  DetectorChoice choice;
  choice.kind = DetectorChoice::kYolo;
  choice.yolo.cfg = slurp(dir + "yolo-fastest-1.1-xl.cfg");
  choice.yolo.weights = slurp(dir + "yolo-fastest-1.1-xl.weights");
  if (choice.yolo.cfg.empty()) return nullptr;
  absl::StatusOr<std::unique_ptr<ObjectDetector>> detector = MakeDetector(choice);
  EXPECT_TRUE(detector.ok()) << detector.status();
  return detector.ok() ? *std::move(detector) : nullptr;
}

std::string BonnGroundTruth() { return kBonn + "groundtruth.txt"; }
std::string KittiGroundTruth() { return kKitti + "poses.txt"; }

RunSummary RunAndEvaluate(VisualOdometry& odometry, const std::vector<RealFrame>& frames,
                          int count, const std::string& groundtruth_path, bool kitti,
                          bool with_scale) {
  RunSummary summary;
  for (int i = 0; i < count && i < static_cast<int>(frames.size()); ++i) {
    FrameInput input;
    input.stamp = frames[i].stamp;
    input.image = cv::imread(frames[i].image_path, cv::IMREAD_COLOR);
    if (!frames[i].depth_path.empty()) {
      input.depth = cv::imread(frames[i].depth_path, cv::IMREAD_UNCHANGED);
    }
    absl::StatusOr<FrameResult> result = odometry.ProcessFrame(input);
    EXPECT_TRUE(result.ok()) << frames[i].image_path << ": " << result.status();
    if (!result.ok()) continue;
    ++summary.frames;
    if (std::getenv("WAYMARK_VO_DEBUG") != nullptr) {
      const FeatureCounts& c = result->counts;
      std::printf("%3d %s kf=%d total=%d pdyn=%d matched=%d dyn=%d tracked=%d mapped=%d "
                  "t=(%.3f %.3f %.3f) rot=%.2f ms=%.1f\n",
                  i, TrackingStateName(result->state), result->keyframe, c.total,
                  c.potentially_dynamic, c.matched, c.dynamic, c.tracked, c.mapped,
                  result->pose.t.x(), result->pose.t.y(), result->pose.t.z(), Eigen::AngleAxisd(result->pose.R).angle() * 57.3,
                  result->timings.total_ms);
    }
    if (result->state == TrackingState::kLost) ++summary.lost;
    summary.dynamic += result->counts.dynamic;
    summary.potentially_dynamic += result->counts.potentially_dynamic;
  }
  // Ground truth: TUM lines "stamp tx ty tz qx qy qz qw" or KITTI 3x4 rows at 10 Hz.
  std::vector<std::pair<double, Eigen::Vector3d>> groundtruth;
  std::ifstream in(groundtruth_path);
  std::string line;
  for (int row = 0; std::getline(in, line); ) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> v;
    for (double x; fields >> x;) v.push_back(x);
    if (kitti && v.size() == 12) groundtruth.push_back({0.1 * row++, {v[3], v[7], v[11]}});
    if (!kitti && v.size() == 8) groundtruth.push_back({v[0], {v[1], v[2], v[3]}});
  }
  // Associate each estimated pose with the ground-truth pose nearest in time (within 20 ms),
  // align (Umeyama, as TUM's evaluate_ate.py) and take the RMSE of the position errors.
  std::vector<Eigen::Vector3d> source, target;
  for (const TimedPose& pose : odometry.trajectory()) {
    double best = 0.02;
    const Eigen::Vector3d* match = nullptr;
    for (const auto& [stamp, position] : groundtruth) {
      if (std::abs(stamp - pose.stamp) < best) {
        best = std::abs(stamp - pose.stamp);
        match = &position;
      }
    }
    if (match == nullptr) continue;
    source.push_back(pose.pose.t);
    target.push_back(*match);
  }
  EXPECT_GE(source.size(), 3u) << "no ground truth matched";
  if (source.size() < 3) return summary;
  Eigen::Matrix3Xd src(3, source.size()), dst(3, target.size());
  for (size_t i = 0; i < source.size(); ++i) {
    src.col(i) = source[i];
    dst.col(i) = target[i];
  }
  const Eigen::Matrix4d alignment = Eigen::umeyama(src, dst, with_scale);
  const Eigen::Matrix3Xd aligned =
      (alignment.topLeftCorner<3, 3>() * src).colwise() + alignment.topRightCorner<3, 1>();
  summary.ate_rmse = std::sqrt((aligned - dst).colwise().squaredNorm().mean());
  return summary;
}

}  // namespace waymark::visual_slam::testing

#ifndef WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_
#define WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_

// Test helpers for the visual odometry engine: synthetic textured frames with a known camera
// motion, and running the engine over a real sequence in ../shared with its ATE.

#include <string>
#include <vector>

#include "server/visual_slam/types.h"
#include "server/visual_slam/visual_odometry.h"

namespace waymark::visual_slam::testing {

// A smooth random texture (blurred noise) large enough to cut shifted views from.
cv::Mat RandomTexture(int width, int height, unsigned seed);

// The camera of the synthetic frames: 640x480, f = 500, no distortion.
CameraModel SyntheticCamera();

struct RealFrame {
  double stamp = 0;
  std::string image_path;
  std::string depth_path;  // empty for monocular sequences
};

// Bonn crowd window (../shared/data/vslam/bonn_rgbd_crowd_frames270-409) frames from its
// associations.txt, and its published intrinsics. Empty when ../shared is absent.
std::vector<RealFrame> BonnFrames();
CameraModel BonnCamera();
// KITTI 06 frames 0-50 (image_0, 10 Hz stamps) and the calib.txt P0 camera.
std::vector<RealFrame> KittiFrames();
CameraModel KittiCamera();

// Runs `odometry` over the first `count` frames; returns the trajectory ATE RMSE (m) against the
// sequence's ground truth, SE(3)-aligned, or Sim(3) when `with_scale`. Counts lost frames.
struct RunSummary {
  double ate_rmse = 0;
  int frames = 0;
  int lost = 0;
  int dynamic = 0;
  int potentially_dynamic = 0;
};
RunSummary RunAndEvaluate(VisualOdometry& odometry, const std::vector<RealFrame>& frames,
                          int count, const std::string& groundtruth_path, bool kitti,
                          bool with_scale);

std::string BonnGroundTruth();
// The YOLO-Fastest detector from ../shared/models (null when absent).
std::unique_ptr<ObjectDetector> SharedYolo();
std::string KittiGroundTruth();

}  // namespace waymark::visual_slam::testing

#endif  // WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_

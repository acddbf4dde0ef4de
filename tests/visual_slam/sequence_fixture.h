#ifndef WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_
#define WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_

// Test helpers for the visual odometry engine: synthetic textured frames with a known camera
// motion, and running the engine over a real sequence in ../shared with its ATE (the sequence
// reader and the ATE are the client's, client/datasets/image_sequence and
// client/eval/trajectory_metrics).

#include <memory>
#include <optional>
#include <string>

#include "client/datasets/image_sequence.h"
#include "server/visual_slam/detectors/object_detector.h"
#include "server/visual_slam/types.h"
#include "server/visual_slam/visual_odometry.h"

namespace waymark::visual_slam::testing {

// A smooth random texture (blurred noise) large enough to cut shifted views from.
cv::Mat RandomTexture(int width, int height, unsigned seed);

// The camera of the synthetic frames: 640x480, f = 500, no distortion.
CameraModel SyntheticCamera();

// The Bonn crowd window and the KITTI 06 frames of ../shared/data/vslam; nullopt when absent.
std::optional<cli::ImageSequence> BonnSequence();
std::optional<cli::ImageSequence> KittiSequence();
// The engine camera for a sequence's frames: the preset's (Bonn) or calib.txt's (KITTI)
// intrinsics and the size of its first image.
CameraModel SequenceCamera(const cli::ImageSequence& sequence, const std::string& preset);

// The YOLO-Fastest detector from ../shared/models (null when absent).
std::unique_ptr<ObjectDetector> SharedYolo();

struct RunSummary {
  double ate_rmse = 0;  // m, SE(3)-aligned, or Sim(3) when `with_scale`
  int frames = 0;
  int lost = 0;
  int dynamic = 0;
  int potentially_dynamic = 0;
};
// Runs `odometry` over the sequence's frames (depth when `with_depth`) and scores its trajectory
// against the sequence's ground truth. WAYMARK_VO_DEBUG=1 prints one line per frame.
RunSummary RunAndEvaluate(VisualOdometry& odometry, const cli::ImageSequence& sequence,
                          bool with_depth, bool with_scale);

}  // namespace waymark::visual_slam::testing

#endif  // WAYMARK_TESTS_VISUAL_SLAM_SEQUENCE_FIXTURE_H_

#ifndef WAYMARK_SERVER_VISUAL_SLAM_TYPES_H_
#define WAYMARK_SERVER_VISUAL_SLAM_TYPES_H_

// Value types shared by the visual odometry engine (METHODS.md section 3): camera model, detector
// boxes, rigid motions and the per-frame result. Plain C++, OpenCV and Eigen; no gRPC, no SQL.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace waymark::visual_slam {

// Pinhole camera with OpenCV's (k1, k2, p1, p2, k3) radial-tangential distortion, in pixels of
// the images the robot sends. Keypoints are undistorted with it before any geometry.
struct CameraModel {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> distortion{};  // k1, k2, p1, p2, k3; all zero = undistorted images
  int width = 0, height = 0;           // pixels; frames of another size are rejected
};

// An axis-aligned detector box in image pixels (eq 7's r = (x, y, w, h)) of a movable class.
struct Box {
  float x = 0, y = 0, w = 0, h = 0;  // top-left corner and size
  std::string label;                 // "person", "car", ... (empty when the robot did not say)
  float confidence = 1;
};

// A rigid motion. As a camera motion between a reference frame r and a current frame c it maps
// reference-camera coordinates to current-camera coordinates: X_c = R * X_r + t.
struct Motion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

// Camera pose in the world (the first frame's camera): X_world = R * X_camera + t.
struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

inline bool IsFinite(const Pose& pose) { return pose.R.allFinite() && pose.t.allFinite(); }

struct TimedPose {
  double stamp = 0;
  Pose pose;
};

// One frame as the engine takes it. The service decodes the robot's JPEG/PNG into these mats.
struct FrameInput {
  double stamp = 0;  // seconds; strictly increasing within a session
  cv::Mat image;     // 8-bit, 1 (gray) or 3 (BGR) channels, CameraModel's size
  cv::Mat depth;     // empty (monocular) or CV_16UC1 of the same size, 0 = no depth
  // Boxes the robot computed itself. Set: used instead of the session's detector for this frame.
  std::optional<std::vector<Box>> boxes;
};

// How a feature of the current frame was classified (for counts and pictures).
enum class FeatureLabel {
  kUnmatched,           // no match to the reference, or matched but not tested
  kStatic,              // passed the static test outside every box: tracked and mapped
  kStaticInBox,         // potentially dynamic but passed the static test: tracked, not mapped
  kDynamic,             // failed the static test: dropped
  kPotentiallyDynamic,  // inside a box and not tested (the boxes-only filter drops these)
};

struct FeatureCounts {
  int total = 0;                // ORB keypoints extracted
  int potentially_dynamic = 0;  // inside a movable-class box (eq 7)
  int matched = 0;              // coarse matches to the reference (eq 8)
  int dynamic = 0;              // failed the static test (eq 17)
  int tracked = 0;              // static features the pose was computed from
  int mapped = 0;               // static features outside boxes added to the map (eq 18)
  int proven = 0;  // kProven: boxed features static long enough to count as mapped (this frame)
};

// Milliseconds spent per stage of one frame.
struct StageTimings {
  double decode_ms = 0;  // filled by the service
  double orb_ms = 0;
  double detector_ms = 0;
  double matching_ms = 0;
  double sampling_ms = 0;
  double pose_ms = 0;
  double mapping_ms = 0;
  double total_ms = 0;
  // The local bundle adjustment applied before this frame (0 when none): its own time, on the
  // session's background thread, and how long this frame waited for it (bundle_wait only).
  double bundle_ms = 0;
  double bundle_wait_ms = 0;
};

enum class TrackingState {
  kInitializing,  // first frame(s): the pose is the origin, no motion yet
  kTracking,      // the pose comes from this frame's features
  kLost,          // too few static matches: the pose is predicted (constant velocity)
};

// How far a frame's pose can be trusted (issue 35): what clients show beside the pose.
struct TrackingQuality {
  enum class Level {
    kInitializing,  // no motion yet
    kGood,
    kWeak,  // tracked, but on few inliers or (monocular) with almost no parallax
    kLost,  // the pose is a prediction
  };
  Level level = Level::kInitializing;
  int inliers = 0;          // of the motion hypothesis the pose comes from
  double parallax_deg = 0;  // median angle between the tracked pairs' rays after the rotation
  std::string reason;       // why kWeak or kLost; empty otherwise
};

// Below these a tracked frame is kWeak: inliers under kWeakInlierFactor * min_tracked, or
// (monocular) a median parallax under kLowParallaxDeg, where the essential matrix cannot tell a
// translation from a rotation (docs/visual-odometry.md, "Tracking quality").
inline constexpr double kWeakInlierFactor = 2.0;
inline constexpr double kLowParallaxDeg = 0.05;

const char* QualityLevelName(TrackingQuality::Level level);

struct FrameResult {
  double stamp = 0;
  Pose pose;
  TrackingState state = TrackingState::kInitializing;
  bool keyframe = false;  // this frame became the new reference
  // Tracked against a keyframe that had left the local map (relocalization_keyframes).
  bool relocalized = false;
  FeatureCounts counts;
  StageTimings timings;
  std::vector<Box> boxes;  // the boxes this frame was split with
  // Per keypoint: pixel position and label (same order), for pictures and tests.
  std::vector<cv::Point2f> keypoints;
  std::vector<FeatureLabel> labels;
  TrackingQuality quality;
  // Warnings about the session itself, on its first frame only: intrinsics that do not fit the
  // images (CameraWarnings in camera_check.h).
  std::vector<std::string> warnings;
};

const char* FeatureLabelName(FeatureLabel label);
const char* TrackingStateName(TrackingState state);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_TYPES_H_

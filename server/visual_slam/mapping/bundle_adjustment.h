#ifndef WAYMARK_SERVER_VISUAL_SLAM_MAPPING_BUNDLE_ADJUSTMENT_H_
#define WAYMARK_SERVER_VISUAL_SLAM_MAPPING_BUNDLE_ADJUSTMENT_H_

// A bundle adjustment of a window of cameras and the points they see (Ceres, Levenberg-Marquardt
// with a sparse Schur solver): every camera pose not marked fixed and every point move to
// minimise the robust (Huber) sum of squared reprojection errors, in pixels, plus, for an
// observation with depth (RGB-D), the error of its virtual stereo disparity (ORB-SLAM2's RGB-D
// residual: bf * (1/z_predicted - 1/z_measured)).
//
// The gauge is the caller's: at least one fixed camera for RGB-D (depth fixes the scale), two for
// monocular (one fixes the frame, the second the scale). Plain C++, Eigen and Ceres; no state.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct BundleCamera {
  Pose pose;           // X_world = R X_camera + t
  bool fixed = false;  // held where it is (the gauge, and cameras older than the window)
};

struct BundleObservation {
  int camera = 0;
  int point = 0;
  Eigen::Vector2d normalized = Eigen::Vector2d::Zero();  // undistorted (x/z, y/z)
  std::optional<double> depth;  // metres along the camera's optical axis (RGB-D)
};

struct BundleProblem {
  std::vector<BundleCamera> cameras;
  std::vector<Eigen::Vector3d> points;  // world coordinates
  std::vector<BundleObservation> observations;
};

struct BundleOptions {
  double focal_px = 500;  // normalized errors times this are pixels
  // Huber scale of the reprojection residual (pixels): errors beyond it count linearly.
  double huber_px = 2.0;
  // Virtual stereo baseline times focal length (pixels x metres) of the depth residual: ORB-SLAM2
  // uses 40 for the TUM Kinect. 0 leaves depth out.
  double stereo_bf = 40;
  // Levenberg-Marquardt iterations per round. Two rounds (ORB-SLAM2's local BA): after the first,
  // observations whose reprojection error exceeds outlier_px are left out of the second, so that
  // gross mismatches do not bend the answer even through the Huber loss.
  int max_iterations = 10;
  int rounds = 2;
  // An observation whose final reprojection error exceeds this (pixels) is reported an outlier.
  double outlier_px = 4.0;
};

struct BundleResult {
  std::vector<Pose> cameras;                // refined (fixed ones unchanged)
  std::vector<Eigen::Vector3d> points;      // refined
  std::vector<bool> outlier;                // per observation
  double initial_cost = 0, final_cost = 0;  // Ceres' (half the robust sum of squares)
  int iterations = 0;
};

// INVALID_ARGUMENT for an index out of range, a non-finite number, or no fixed camera.
absl::StatusOr<BundleResult> BundleAdjust(const BundleProblem& problem,
                                          const BundleOptions& options);

// The reprojection error (pixels) of `observation` given a camera pose and a world point; +inf
// when the point is not in front of the camera.
double ReprojectionErrorPx(const Pose& camera, const Eigen::Vector3d& point,
                           const Eigen::Vector2d& normalized, double focal_px);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_MAPPING_BUNDLE_ADJUSTMENT_H_

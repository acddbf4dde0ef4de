#ifndef WAYMARK_SERVER_VISUAL_SLAM_FRAME_FEATURES_H_
#define WAYMARK_SERVER_VISUAL_SLAM_FRAME_FEATURES_H_

// ORB features of one frame (METHODS.md section 3: FAST corners with intensity-centroid
// orientation, rotated BRIEF, over an image pyramid), with their undistorted normalized
// coordinates and, for RGB-D frames, their depth.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "server/visual_slam/options.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct FrameFeatures {
  std::vector<cv::Point2f> pixels;         // as detected, in the (distorted) image
  std::vector<Eigen::Vector2d> normalized;  // undistorted (x/z, y/z)
  cv::Mat descriptors;                     // CV_8U, one 32-byte row per feature
  // Metres along the optical axis (RGB-D), from the depth pixel under the keypoint; unset when
  // the frame has no depth or the reading is missing or outside [min_depth, max_depth].
  std::vector<std::optional<double>> depth;

  int size() const { return static_cast<int>(pixels.size()); }
  // The 3-D point of feature i in its camera, when it has depth.
  std::optional<Eigen::Vector3d> Point(int i) const;
};

// Extracts ORB features. Keeps one extractor (OpenCV's ORB object) so repeated calls reuse its
// buffers.
class OrbExtractor {
 public:
  OrbExtractor(const OrbOptions& options, const CameraModel& camera);
  // `gray`: 8-bit single channel of the camera's size. `depth`: empty or CV_16UC1, raw units.
  FrameFeatures Extract(const cv::Mat& gray, const cv::Mat& depth, double depth_scale,
                        double min_depth, double max_depth);

 private:
  cv::Ptr<cv::ORB> orb_;
  cv::Mat camera_matrix_;
  cv::Mat distortion_;
};

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_FRAME_FEATURES_H_

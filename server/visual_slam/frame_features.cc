#include "server/visual_slam/frame_features.h"

#include <cmath>

#include <opencv2/calib3d.hpp>

namespace waymark::visual_slam {

std::optional<Eigen::Vector3d> FrameFeatures::Point(int i) const {
  if (!depth[i]) return std::nullopt;
  return Eigen::Vector3d(normalized[i].x(), normalized[i].y(), 1.0) * *depth[i];
}

OrbExtractor::OrbExtractor(const OrbOptions& options, const CameraModel& camera)
    : orb_(cv::ORB::create(options.features, options.scale_factor, options.levels,
                           /*edgeThreshold=*/31, /*firstLevel=*/0, /*WTA_K=*/2,
                           cv::ORB::HARRIS_SCORE, /*patchSize=*/31, options.fast_threshold)),
      camera_matrix_((cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy,
                      0, 0, 1)),
      distortion_(cv::Mat(camera.distortion.size(), 1, CV_64F).clone()) {
  for (size_t i = 0; i < camera.distortion.size(); ++i) {
    distortion_.at<double>(static_cast<int>(i)) = camera.distortion[i];
  }
}

FrameFeatures OrbExtractor::Extract(const cv::Mat& gray, const cv::Mat& depth, double depth_scale,
                                    double min_depth, double max_depth) {
  std::vector<cv::KeyPoint> keypoints;
  FrameFeatures out;
  orb_->detectAndCompute(gray, cv::noArray(), keypoints, out.descriptors);
  const int n = static_cast<int>(keypoints.size());
  out.pixels.reserve(n);
  for (const cv::KeyPoint& k : keypoints) out.pixels.push_back(k.pt);
  out.normalized.resize(n);
  out.depth.assign(n, std::nullopt);
  if (n == 0) return out;

  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(out.pixels, undistorted, camera_matrix_, distortion_);
  for (int i = 0; i < n; ++i) out.normalized[i] = {undistorted[i].x, undistorted[i].y};

  if (!depth.empty()) {
    // The depth image is registered to the colour image as recorded (distorted), so the
    // reading under the keypoint's detected pixel is the one that belongs to it.
    for (int i = 0; i < n; ++i) {
      const int u = static_cast<int>(std::lround(out.pixels[i].x));
      const int v = static_cast<int>(std::lround(out.pixels[i].y));
      if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
      const double metres = depth.at<uint16_t>(v, u) / depth_scale;
      if (metres >= min_depth && metres <= max_depth) out.depth[i] = metres;
    }
  }
  return out;
}

}  // namespace waymark::visual_slam

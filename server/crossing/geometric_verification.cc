#include "server/crossing/geometric_verification.h"

#include <opencv2/calib3d.hpp>

namespace waymark::crossing {

std::optional<cv::Matx33d> EstimateFundamental(const std::vector<cv::Point2f>& query_points,
                                               const std::vector<cv::Point2f>& view_points,
                                               const VerificationOptions& options,
                                               std::vector<uchar>* inlier_mask) {
  if (query_points.size() != view_points.size() || query_points.size() < 8) return std::nullopt;
  std::vector<uchar> mask;
  cv::Mat f;
  try {
    cv::setRNGSeed(options.seed);
    f = cv::findFundamentalMat(query_points, view_points, cv::FM_RANSAC, options.threshold_px,
                               options.confidence, options.max_iterations, mask);
  } catch (const cv::Exception&) {
    return std::nullopt;  // degenerate configuration: no geometry
  }
  // Up to three solutions come stacked (9 x 3); RANSAC returns one.
  if (f.rows != 3 || f.cols != 3) return std::nullopt;
  if (inlier_mask != nullptr) *inlier_mask = std::move(mask);
  cv::Mat f64;
  f.convertTo(f64, CV_64F);
  return cv::Matx33d(f64.ptr<double>());
}

int CountEpipolarInliers(const std::vector<cv::Point2f>& query_points,
                         const std::vector<cv::Point2f>& view_points,
                         const VerificationOptions& options, std::vector<uchar>* inlier_mask) {
  std::vector<uchar> mask;
  if (!EstimateFundamental(query_points, view_points, options, &mask)) return 0;
  const int inliers = cv::countNonZero(mask);
  if (inlier_mask != nullptr) *inlier_mask = std::move(mask);
  return inliers;
}

}  // namespace waymark::crossing

#include "server/crossing/geometric_verification.h"

#include <opencv2/calib3d.hpp>

namespace waymark::crossing {

int CountEpipolarInliers(const std::vector<cv::Point2f>& query_points,
                         const std::vector<cv::Point2f>& view_points,
                         const VerificationOptions& options, std::vector<uchar>* inlier_mask) {
  if (query_points.size() != view_points.size() || query_points.size() < 8) return 0;
  std::vector<uchar> mask;
  try {
    cv::setRNGSeed(options.seed);
    const cv::Mat f = cv::findFundamentalMat(query_points, view_points, cv::FM_RANSAC,
                                             options.threshold_px, options.confidence,
                                             options.max_iterations, mask);
    if (f.empty()) return 0;
  } catch (const cv::Exception&) {
    return 0;  // degenerate configuration: no geometry, no inliers
  }
  if (inlier_mask != nullptr) *inlier_mask = mask;
  return cv::countNonZero(mask);
}

}  // namespace waymark::crossing

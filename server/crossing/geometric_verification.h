#ifndef WAYMARK_SERVER_CROSSING_GEOMETRIC_VERIFICATION_H_
#define WAYMARK_SERVER_CROSSING_GEOMETRIC_VERIFICATION_H_

// Beyond the paper: tentative matches between a query and a view are kept only if they agree
// with one epipolar geometry (RANSAC on the fundamental matrix). A robot a few metres from where a
// view was captured sees the same scene from another viewpoint, so a homography would be too
// strict; the fundamental matrix allows any rigid camera motion.

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

namespace waymark::crossing {

struct VerificationOptions {
  double threshold_px = 3.0;   // max distance to the epipolar line
  double confidence = 0.99;
  int max_iterations = 500;
  int seed = 12345;  // RANSAC is seeded per call: the same query gives the same answer
};

// Number of inlier correspondences; 0 when fewer than 8 pairs (the 8-point minimum) or when no
// geometry is found. `inlier_mask`, if given, gets one flag per pair.
int CountEpipolarInliers(const std::vector<cv::Point2f>& query_points,
                         const std::vector<cv::Point2f>& view_points,
                         const VerificationOptions& options,
                         std::vector<uchar>* inlier_mask = nullptr);

// The RANSAC fundamental matrix itself (view^T F query = 0), or an empty optional when fewer than
// 8 pairs or no geometry is found.
std::optional<cv::Matx33d> EstimateFundamental(const std::vector<cv::Point2f>& query_points,
                                               const std::vector<cv::Point2f>& view_points,
                                               const VerificationOptions& options,
                                               std::vector<uchar>* inlier_mask = nullptr);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_GEOMETRIC_VERIFICATION_H_

#include "server/visual_slam/coarse_matching.h"

#include <algorithm>

#include <opencv2/features2d.hpp>

namespace waymark::visual_slam {

std::vector<DescriptorMatch> CoarseMatch(const cv::Mat& query, const cv::Mat& train, int delta,
                                         double ratio) {
  std::vector<DescriptorMatch> out;
  if (query.empty() || train.empty()) return out;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 2);

  std::vector<int> best_query_for_train(train.rows, -1);
  std::vector<int> best_distance_for_train(train.rows, 1 << 30);
  for (const std::vector<cv::DMatch>& pair : knn) {
    if (pair.empty()) continue;
    const cv::DMatch& best = pair[0];
    const int distance = static_cast<int>(best.distance);
    if (distance >= delta) continue;
    if (pair.size() > 1 && best.distance >= ratio * pair[1].distance) continue;
    if (distance < best_distance_for_train[best.trainIdx]) {
      best_distance_for_train[best.trainIdx] = distance;
      best_query_for_train[best.trainIdx] = best.queryIdx;
    }
  }
  for (int t = 0; t < train.rows; ++t) {
    if (best_query_for_train[t] >= 0) {
      out.push_back({best_query_for_train[t], t, best_distance_for_train[t]});
    }
  }
  std::sort(out.begin(), out.end(), [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.query < b.query;
  });
  return out;
}

}  // namespace waymark::visual_slam

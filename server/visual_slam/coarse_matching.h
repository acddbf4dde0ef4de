#ifndef WAYMARK_SERVER_VISUAL_SLAM_COARSE_MATCHING_H_
#define WAYMARK_SERVER_VISUAL_SLAM_COARSE_MATCHING_H_

// eq 8: coarse matching of the current frame's ORB descriptors to the reference's by Hamming
// distance.

#include <vector>

#include <opencv2/core.hpp>

namespace waymark::visual_slam {

struct DescriptorMatch {
  int query = 0;     // row of the current frame's descriptors
  int train = 0;     // row of the reference's descriptors
  int distance = 0;  // Hamming distance in bits
};

// For each query row, its nearest train row when the distance is below `delta` and below
// `ratio` times the second nearest (the ratio test drops repetitive texture, where the nearest
// neighbour is a coin toss). A train row matched by several queries keeps only the closest one,
// so every reference feature contributes at most one pair. Sorted by query.
std::vector<DescriptorMatch> CoarseMatch(const cv::Mat& query, const cv::Mat& train, int delta,
                                         double ratio);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_COARSE_MATCHING_H_

#ifndef WAYMARK_BENCH_COMMON_BENCH_IMAGES_H_
#define WAYMARK_BENCH_COMMON_BENCH_IMAGES_H_

// Real images for the latency benchmark, read in place from ../shared/data, and augmented copies to
// grow a database to thousands of views (flips, crops, small rotations, gamma: each copy has
// its own descriptors, unlike a byte-identical duplicate).

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace waymark::bench {

// Every usable image under the shared data folder, in a fixed order: corridor references first
// (so the smallest database holds the places the corridor queries show), then the rest.
std::vector<std::string> DatabaseSourceImages(const std::string& shared_dir);
// Held-out query images: the corridor query traversal.
std::vector<std::string> QueryImages(const std::string& shared_dir);

// A robot's second visit to a stored view, at 320x240: a little closer (92 % crop), darker and
// blurred. Recognizable, so a query exercises every step of the method.
cv::Mat Revisit(const cv::Mat& image);

// Augmented variant `k` (0 = the original) of an image, at 320x240.
cv::Mat Augment(const cv::Mat& image, int k);
inline constexpr int kAugmentations = 12;

}  // namespace waymark::bench

#endif  // WAYMARK_BENCH_COMMON_BENCH_IMAGES_H_

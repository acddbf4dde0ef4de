#ifndef WAYMARK_TESTS_SUPPORT_RANDOM_DESCRIPTORS_H_
#define WAYMARK_TESTS_SUPPORT_RANDOM_DESCRIPTORS_H_

// Random 128-byte descriptors with known geometry, for matcher tests and benchmarks: uniform
// descriptors are far apart (about 1,180 in L2), perturbed copies are near their originals.

#include <random>

#include <opencv2/core.hpp>

namespace waymark::testing {

// n x 128 CV_8U, each byte uniform in [0, 255].
cv::Mat RandomDescriptors(int n, std::mt19937* rng);

// A copy with every byte moved by a uniform amount in [-amplitude, amplitude] (saturated).
cv::Mat Perturb(const cv::Mat& descriptors, int amplitude, std::mt19937* rng);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_RANDOM_DESCRIPTORS_H_

#include "tests/support/random_descriptors.h"

namespace waymark::testing {

cv::Mat RandomDescriptors(int n, std::mt19937* rng) {
  cv::Mat d(n, 128, CV_8U);
  std::uniform_int_distribution<int> u(0, 255);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 128; ++k) d.at<uint8_t>(i, k) = static_cast<uint8_t>(u(*rng));
  }
  return d;
}

cv::Mat Perturb(const cv::Mat& descriptors, int amplitude, std::mt19937* rng) {
  cv::Mat out = descriptors.clone();
  std::uniform_int_distribution<int> u(-amplitude, amplitude);
  for (int i = 0; i < out.rows; ++i) {
    for (int k = 0; k < 128; ++k) {
      out.at<uint8_t>(i, k) = cv::saturate_cast<uint8_t>(out.at<uint8_t>(i, k) + u(*rng));
    }
  }
  return out;
}

}  // namespace waymark::testing

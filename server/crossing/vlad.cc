#include "server/crossing/vlad.h"

#include <cmath>

#include <opencv2/core.hpp>

namespace waymark::crossing {

VladVocabulary VladVocabulary::Train(const cv::Mat& descriptors, int words, int max_samples) {
  VladVocabulary v;
  if (descriptors.rows < words || words < 1) return v;
  cv::Mat data;
  descriptors.convertTo(data, CV_32F);
  if (data.rows > max_samples) {
    // Every n-th row: deterministic, and spread over all views.
    const int step = (data.rows + max_samples - 1) / max_samples;
    cv::Mat sample;
    for (int r = 0; r < data.rows; r += step) sample.push_back(data.row(r));
    data = sample;
  }
  cv::setRNGSeed(4242);
  cv::Mat labels;
  cv::kmeans(data, words, labels,
             cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 20, 1e-3), 1,
             cv::KMEANS_PP_CENTERS, v.centers_);
  return v;
}

cv::Mat VladVocabulary::Encode(const cv::Mat& descriptors) const {
  const int d = centers_.cols;
  cv::Mat vlad = cv::Mat::zeros(1, words() * d, CV_32F);
  if (empty() || descriptors.rows == 0) return vlad;
  cv::Mat data;
  descriptors.convertTo(data, CV_32F);
  // The nearest word of every descriptor in one call (OpenCV's brute-force distance kernel).
  cv::Mat distances, nearest;
  cv::batchDistance(data, centers_, distances, CV_32F, nearest, cv::NORM_L2SQR, 1);
  float* out = vlad.ptr<float>(0);
  for (int i = 0; i < data.rows; ++i) {
    const int word = nearest.at<int>(i);
    const float* x = data.ptr<float>(i);
    const float* c = centers_.ptr<float>(word);
    for (int k = 0; k < d; ++k) out[word * d + k] += x[k] - c[k];
  }
  for (int j = 0; j < words() * d; ++j) {
    out[j] = std::copysign(std::sqrt(std::abs(out[j])), out[j]);
  }
  for (int w = 0; w < words(); ++w) {
    const double n = cv::norm(vlad.colRange(w * d, (w + 1) * d));
    if (n > 0) vlad.colRange(w * d, (w + 1) * d) /= n;
  }
  const double n = cv::norm(vlad);
  if (n > 0) vlad /= n;
  return vlad;
}

}  // namespace waymark::crossing

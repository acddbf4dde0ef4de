#include "server/crossing/vlad.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "absl/strings/str_cat.h"

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

cv::Mat EvenRows(const cv::Mat& rows, int count) {
  if (rows.rows <= count) return rows;
  cv::Mat out;
  if (count <= 0) return out;
  const double step = static_cast<double>(rows.rows) / count;
  for (int i = 0; i < count; ++i) out.push_back(rows.row(static_cast<int>(i * step)));
  return out;
}

VladVocabulary VladVocabulary::TrainOnImages(const std::vector<cv::Mat>& descriptors, int words,
                                             int max_samples) {
  if (descriptors.empty()) return {};
  const int per_image = std::max<int>(1, max_samples / static_cast<int>(descriptors.size()));
  cv::Mat sample;
  for (const cv::Mat& d : descriptors) {
    if (!d.empty()) sample.push_back(EvenRows(d, per_image));
  }
  return Train(sample, words, max_samples);
}

uint64_t VladVocabulary::Fingerprint() const {
  if (empty()) return 0;
  const cv::Mat c = centers_.isContinuous() ? centers_ : centers_.clone();
  const auto* bytes = c.ptr<uint8_t>(0);
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < c.total() * c.elemSize(); ++i) {
    h = (h ^ bytes[i]) * 1099511628211ull;
  }
  return h;
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

namespace {
// "WMVL", format 1, words, dimensions; then words x dimensions floats (x86-64 and ARM64 are both
// little-endian; the header's magic would not match on a big-endian reader).
constexpr char kMagic[4] = {'W', 'M', 'V', 'L'};
constexpr int32_t kFormat = 1;
constexpr size_t kHeader = sizeof(kMagic) + 3 * sizeof(int32_t);
}  // namespace

std::string VladVocabulary::Serialize() const {
  const int32_t header[3] = {kFormat, centers_.rows, centers_.cols};
  std::string out(kHeader + centers_.total() * sizeof(float), '\0');
  std::memcpy(out.data(), kMagic, sizeof(kMagic));
  std::memcpy(out.data() + sizeof(kMagic), header, sizeof(header));
  if (!centers_.empty()) {
    const cv::Mat c = centers_.isContinuous() ? centers_ : centers_.clone();
    std::memcpy(out.data() + kHeader, c.ptr<float>(0), c.total() * sizeof(float));
  }
  return out;
}

absl::StatusOr<VladVocabulary> VladVocabulary::Deserialize(const std::string& bytes) {
  int32_t header[3] = {0, 0, 0};
  if (bytes.size() < kHeader || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    return absl::InvalidArgumentError("not a VLAD vocabulary (bad header)");
  }
  std::memcpy(header, bytes.data() + sizeof(kMagic), sizeof(header));
  if (header[0] != kFormat) {
    return absl::InvalidArgumentError(
        absl::StrCat("VLAD vocabulary format ", header[0], ", this build reads ", kFormat));
  }
  const int64_t words = header[1], dims = header[2];
  if (words < 0 || dims < 0 || words > 65536 || dims > 4096 ||
      bytes.size() != kHeader + size_t(words * dims) * sizeof(float)) {
    return absl::InvalidArgumentError(absl::StrCat("VLAD vocabulary of ", words, " x ", dims,
                                                   " words does not fit its ", bytes.size(),
                                                   " bytes"));
  }
  VladVocabulary v;
  if (words > 0 && dims > 0) {
    v.centers_.create(static_cast<int>(words), static_cast<int>(dims), CV_32F);
    std::memcpy(v.centers_.ptr<float>(0), bytes.data() + kHeader, v.centers_.total() * sizeof(float));
  }
  return v;
}

}  // namespace waymark::crossing

#include "server/crossing/vlad.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"

#include <opencv2/core.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

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

int VocabularyScheduleSize(int views, int first, int last) {
  if (first < 1 || views < first) return 0;
  int size = first;
  while (size * 2 <= std::min(views, last)) size *= 2;
  return size;
}

VladVocabulary VladVocabulary::TrainOnFirstImages(const std::vector<cv::Mat>& descriptors,
                                                  int views, int words, int max_samples) {
  const size_t n = std::min(descriptors.size(), static_cast<size_t>(std::max(0, views)));
  return TrainOnImages(std::vector<cv::Mat>(descriptors.begin(), descriptors.begin() + n), words,
                       max_samples);
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

namespace {

// The nearest word of each row of `data` (N x D CV_32F), by the largest x . c - |c|^2 / 2 (the
// smallest squared distance), given `words_t` = the centres transposed (D x K, K a multiple of 8)
// and `half_norms` (K).
void NearestWordsScalar(const cv::Mat& data, const cv::Mat& words_t, const float* half_norms,
                        int* nearest) {
  const int d = data.cols, k = words_t.cols;
  std::vector<float> score(k);
  for (int i = 0; i < data.rows; ++i) {
    const float* x = data.ptr<float>(i);
    for (int w = 0; w < k; ++w) score[w] = -half_norms[w];
    for (int j = 0; j < d; ++j) {
      const float* c = words_t.ptr<float>(j);
      for (int w = 0; w < k; ++w) score[w] += x[j] * c[w];
    }
    nearest[i] = static_cast<int>(std::max_element(score.begin(), score.end()) - score.begin());
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
// The same with AVX2 + FMA, two rows and 32 words per pass (8 accumulators, each load of the
// centres serving both rows): several times OpenCV's brute-force distance kernel
// (cv::batchDistance) that this replaces. K must be a multiple of 32.
__attribute__((target("avx2,fma"))) void NearestWordsAvx2(const cv::Mat& data,
                                                          const cv::Mat& words_t,
                                                          const float* half_norms, int* nearest) {
  const int d = data.cols, k = words_t.cols;
  std::vector<float> score0(k), score1(k);
  const __m256 sign = _mm256_set1_ps(-0.f);
  for (int i = 0; i < data.rows; i += 2) {
    const float* x0 = data.ptr<float>(i);
    const float* x1 = data.ptr<float>(std::min(i + 1, data.rows - 1));
    for (int w0 = 0; w0 < k; w0 += 32) {
      __m256 a0 = _mm256_xor_ps(_mm256_loadu_ps(half_norms + w0), sign);
      __m256 a1 = _mm256_xor_ps(_mm256_loadu_ps(half_norms + w0 + 8), sign);
      __m256 a2 = _mm256_xor_ps(_mm256_loadu_ps(half_norms + w0 + 16), sign);
      __m256 a3 = _mm256_xor_ps(_mm256_loadu_ps(half_norms + w0 + 24), sign);
      __m256 b0 = a0, b1 = a1, b2 = a2, b3 = a3;
      for (int j = 0; j < d; ++j) {
        const float* c = words_t.ptr<float>(j) + w0;
        const __m256 c0 = _mm256_loadu_ps(c), c1 = _mm256_loadu_ps(c + 8);
        const __m256 c2 = _mm256_loadu_ps(c + 16), c3 = _mm256_loadu_ps(c + 24);
        const __m256 u = _mm256_set1_ps(x0[j]), v = _mm256_set1_ps(x1[j]);
        a0 = _mm256_fmadd_ps(u, c0, a0);
        a1 = _mm256_fmadd_ps(u, c1, a1);
        a2 = _mm256_fmadd_ps(u, c2, a2);
        a3 = _mm256_fmadd_ps(u, c3, a3);
        b0 = _mm256_fmadd_ps(v, c0, b0);
        b1 = _mm256_fmadd_ps(v, c1, b1);
        b2 = _mm256_fmadd_ps(v, c2, b2);
        b3 = _mm256_fmadd_ps(v, c3, b3);
      }
      _mm256_storeu_ps(score0.data() + w0, a0);
      _mm256_storeu_ps(score0.data() + w0 + 8, a1);
      _mm256_storeu_ps(score0.data() + w0 + 16, a2);
      _mm256_storeu_ps(score0.data() + w0 + 24, a3);
      _mm256_storeu_ps(score1.data() + w0, b0);
      _mm256_storeu_ps(score1.data() + w0 + 8, b1);
      _mm256_storeu_ps(score1.data() + w0 + 16, b2);
      _mm256_storeu_ps(score1.data() + w0 + 24, b3);
    }
    nearest[i] = static_cast<int>(std::max_element(score0.begin(), score0.end()) - score0.begin());
    if (i + 1 < data.rows) {
      nearest[i + 1] =
          static_cast<int>(std::max_element(score1.begin(), score1.end()) - score1.begin());
    }
  }
}
#endif

}  // namespace

cv::Mat VladVocabulary::Encode(const cv::Mat& descriptors) const {
  const int d = centers_.cols;
  cv::Mat vlad = cv::Mat::zeros(1, words() * d, CV_32F);
  if (empty() || descriptors.rows == 0) return vlad;
  cv::Mat data;
  descriptors.convertTo(data, CV_32F);
  // The nearest word of every descriptor: x . c - |c|^2 / 2 over the words, as one matrix product.
  std::vector<int> nearest(data.rows);
  if (words() % 32 == 0) {
    cv::Mat words_t = centers_.t();
    std::vector<float> half_norms(words());
    for (int w = 0; w < words(); ++w) {
      half_norms[w] = 0.5f * static_cast<float>(centers_.row(w).dot(centers_.row(w)));
    }
    auto kernel = &NearestWordsScalar;
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    if (avx2) kernel = &NearestWordsAvx2;
#endif
    kernel(data, words_t, half_norms.data(), nearest.data());
  } else {
    cv::Mat distances, best;
    cv::batchDistance(data, centers_, distances, CV_32F, best, cv::NORM_L2SQR, 1);
    for (int i = 0; i < data.rows; ++i) nearest[i] = best.at<int>(i);
  }
  // Residuals summed per word: the descriptors' sum minus count x the centre.
  float* out = vlad.ptr<float>(0);
  std::vector<int> count(words(), 0);
  for (int i = 0; i < data.rows; ++i) {
    const int word = nearest[i];
    ++count[word];
    const float* x = data.ptr<float>(i);
    float* o = out + word * d;
    for (int k = 0; k < d; ++k) o[k] += x[k];
  }
  for (int w = 0; w < words(); ++w) {
    if (count[w] == 0) continue;
    const float* c = centers_.ptr<float>(w);
    float* o = out + w * d;
    for (int k = 0; k < d; ++k) o[k] -= count[w] * c[k];
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

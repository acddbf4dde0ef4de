#include "server/crossing/global_index.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "absl/strings/str_cat.h"

namespace waymark::crossing {

GlobalCode QuantizeGlobal(const cv::Mat& unit) {
  GlobalCode code;
  cv::Mat v;
  unit.reshape(1, 1).convertTo(v, CV_32F);
  double max_abs = 0;
  cv::minMaxLoc(cv::abs(v), nullptr, &max_abs);
  code.values.assign(v.cols, 0);
  if (max_abs <= 0) return code;
  const double to_int8 = 127.0 / max_abs;
  const float* x = v.ptr<float>(0);
  double norm2 = 0;
  for (int i = 0; i < v.cols; ++i) {
    code.values[i] = static_cast<int8_t>(std::lround(x[i] * to_int8));
    norm2 += double(code.values[i]) * code.values[i];
  }
  // The reciprocal norm of the integers, so that the similarity of two codes is a cosine.
  code.scale = static_cast<float>(1.0 / std::sqrt(norm2));
  return code;
}

namespace {
// "WMGC", then the vocabulary fingerprint, the scale, the value count and the values.
constexpr char kCodeMagic[4] = {'W', 'M', 'G', 'C'};
constexpr size_t kCodeHeader = sizeof(kCodeMagic) + sizeof(uint64_t) + sizeof(float) +
                               sizeof(int32_t);
}  // namespace

std::string SerializeGlobalCode(const StoredGlobalCode& stored) {
  const int32_t count = static_cast<int32_t>(stored.code.values.size());
  std::string out(kCodeHeader + stored.code.values.size(), '\0');
  char* p = out.data();
  std::memcpy(p, kCodeMagic, sizeof(kCodeMagic));
  std::memcpy(p += sizeof(kCodeMagic), &stored.vocabulary, sizeof(uint64_t));
  std::memcpy(p += sizeof(uint64_t), &stored.code.scale, sizeof(float));
  std::memcpy(p += sizeof(float), &count, sizeof(int32_t));
  if (count > 0) std::memcpy(p + sizeof(int32_t), stored.code.values.data(), count);
  return out;
}

absl::StatusOr<StoredGlobalCode> DeserializeGlobalCode(const std::string& bytes) {
  if (bytes.size() < kCodeHeader || std::memcmp(bytes.data(), kCodeMagic, sizeof(kCodeMagic))) {
    return absl::InvalidArgumentError("not a global code (bad header)");
  }
  StoredGlobalCode stored;
  int32_t count = 0;
  const char* p = bytes.data();
  std::memcpy(&stored.vocabulary, p += sizeof(kCodeMagic), sizeof(uint64_t));
  std::memcpy(&stored.code.scale, p += sizeof(uint64_t), sizeof(float));
  std::memcpy(&count, p += sizeof(float), sizeof(int32_t));
  if (count < 0 || bytes.size() != kCodeHeader + size_t(count) ||
      !std::isfinite(stored.code.scale)) {
    return absl::InvalidArgumentError(
        absl::StrCat("global code of ", count, " values does not fit its ", bytes.size(), " bytes"));
  }
  stored.code.values.resize(count);
  if (count > 0) std::memcpy(stored.code.values.data(), p + sizeof(int32_t), count);
  return stored;
}

void GlobalIndex::Reset(int dims) {
  dims_ = std::max(0, dims);
  blocks_ = (dims_ + kBlockDims - 1) / kBlockDims;
  codes_.clear();
  scales_.clear();
}

namespace {

// 4-bit levels of a code: round(v / step) clipped to [-7, 7], step 0.34 x the RMS of its nonzero
// values (Max's uniform quantiser for a Gaussian with 15-16 levels: 0.335 sigma). A VLAD of few
// descriptors leaves whole words at 0: they stay 0, and do not shrink the step of the others.
// Codes already in [-7, 7] are kept.
std::vector<int8_t> FourBitLevels(const std::vector<int8_t>& values, bool* exact) {
  int max_abs = 0;
  double sum2 = 0;
  size_t nonzero = 0;
  for (int8_t v : values) {
    max_abs = std::max(max_abs, std::abs(int(v)));
    sum2 += double(v) * v;
    nonzero += v != 0;
  }
  *exact = max_abs <= 7;
  if (*exact) return values;
  std::vector<int8_t> levels(values.size(), 0);
  const double rms = std::sqrt(sum2 / std::max<size_t>(1, nonzero));
  const double step = 0.34 * rms;
  if (step <= 0) return levels;
  for (size_t i = 0; i < values.size(); ++i) {
    const long q = std::lround(values[i] / step);
    levels[i] = static_cast<int8_t>(std::clamp<long>(q, -7, 7));
  }
  return levels;
}

}  // namespace

void GlobalIndex::Set(uint32_t slot, const GlobalCode& code) {
  if (slot >= scales_.size()) {
    scales_.resize(slot + 1, 0.f);
    codes_.resize(scales_.size() * packed_bytes(), 0x88);
  }
  uint8_t* packed = codes_.data() + size_t(slot) * packed_bytes();
  if (static_cast<int>(code.values.size()) != dims_ || code.scale == 0) {
    std::fill(packed, packed + packed_bytes(), 0x88);
    scales_[slot] = 0;
    return;
  }
  bool exact = false;
  const std::vector<int8_t> levels = FourBitLevels(code.values, &exact);
  double norm2 = 0;
  std::fill(packed, packed + packed_bytes(), 0x88);  // every nibble 8: the value 0
  for (int i = 0; i < dims_; ++i) {
    const int block = i / kBlockDims, within = i % kBlockDims;
    uint8_t& byte = packed[block * (kBlockDims / 2) + within % (kBlockDims / 2)];
    const uint8_t nibble = static_cast<uint8_t>(levels[i] + 8);
    byte = within < kBlockDims / 2 ? static_cast<uint8_t>((byte & 0xF0) | nibble)
                                   : static_cast<uint8_t>((byte & 0x0F) | (nibble << 4));
    norm2 += double(levels[i]) * levels[i];
  }
  scales_[slot] = exact ? code.scale : norm2 > 0 ? static_cast<float>(1.0 / std::sqrt(norm2)) : 0.f;
}

size_t GlobalIndex::coded() const {
  return static_cast<size_t>(std::count_if(scales_.begin(), scales_.end(),
                                           [](float s) { return s != 0; }));
}

GlobalCode GlobalIndex::Get(uint32_t slot) const {
  GlobalCode code;
  if (slot >= scales_.size() || scales_[slot] == 0) return code;
  const uint8_t* packed = codes_.data() + size_t(slot) * packed_bytes();
  code.values.resize(dims_);
  for (int i = 0; i < dims_; ++i) {
    const int block = i / kBlockDims, within = i % kBlockDims;
    const uint8_t byte = packed[block * (kBlockDims / 2) + within % (kBlockDims / 2)];
    const int nibble = within < kBlockDims / 2 ? (byte & 0x0F) : (byte >> 4);
    code.values[i] = static_cast<int8_t>(nibble - 8);
  }
  code.scale = scales_[slot];
  return code;
}

namespace {

// sum over the blocks of q . nibbles (the nibbles as stored, value + 8): the scan's inner loop.
// `q` is the query padded to whole blocks.
int32_t DotNibblesScalar(const int8_t* q, const uint8_t* packed, int blocks) {
  int32_t dot = 0;
  for (int b = 0; b < blocks; ++b) {
    const int8_t* qb = q + b * GlobalIndex::kBlockDims;
    const uint8_t* pb = packed + b * (GlobalIndex::kBlockDims / 2);
    for (int j = 0; j < GlobalIndex::kBlockDims / 2; ++j) {
      dot += int32_t(qb[j]) * (pb[j] & 0x0F) + int32_t(qb[j + 32]) * (pb[j] >> 4);
    }
  }
  return dot;
}

#if defined(__x86_64__) && defined(__GNUC__)
// AVX2: 64 dimensions per step; maddubs multiplies the unsigned nibbles (<= 15) by the signed
// query bytes and adds pairs (|sum| <= 2 x 15 x 128, no saturation), madd widens to 32 bits.
__attribute__((target("avx2"))) int32_t DotNibblesAvx2(const int8_t* q, const uint8_t* packed,
                                                       int blocks) {
  const __m256i low = _mm256_set1_epi8(0x0F);
  const __m256i ones = _mm256_set1_epi16(1);
  __m256i acc = _mm256_setzero_si256();
  // Up to 4 blocks add up in 16 bits (each lane at most 4 x 2 x 2 x 15 x 127 = 30480) before one
  // widening.
  for (int b0 = 0; b0 < blocks; b0 += 4) {
    __m256i pairs = _mm256_setzero_si256();
    const int end = std::min(blocks, b0 + 4);
    for (int b = b0; b < end; ++b) {
      const __m256i bytes =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(packed + b * 32));
      const __m256i lo = _mm256_and_si256(bytes, low);
      const __m256i hi = _mm256_and_si256(_mm256_srli_epi16(bytes, 4), low);
      const __m256i q0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q + b * 64));
      const __m256i q1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q + b * 64 + 32));
      pairs = _mm256_add_epi16(pairs, _mm256_add_epi16(_mm256_maddubs_epi16(lo, q0),
                                                       _mm256_maddubs_epi16(hi, q1)));
    }
    acc = _mm256_add_epi32(acc, _mm256_madd_epi16(pairs, ones));
  }
  const __m128i sum4 = _mm_add_epi32(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
  const __m128i sum2 = _mm_add_epi32(sum4, _mm_shuffle_epi32(sum4, _MM_SHUFFLE(1, 0, 3, 2)));
  const __m128i sum1 = _mm_add_epi32(sum2, _mm_shuffle_epi32(sum2, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtsi128_si32(sum1);
}

bool HasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#endif

}  // namespace

std::vector<float> GlobalIndex::Similarities(const GlobalCode& query) const {
  std::vector<float> out(scales_.size(), 0.f);
  if (static_cast<int>(query.values.size()) != dims_ || query.scale == 0 || dims_ == 0) return out;
  // The query padded to whole blocks; the stored nibbles are value + 8, so each dot product
  // carries 8 x the query's sum, taken off once per view.
  std::vector<int8_t> q(static_cast<size_t>(blocks_) * kBlockDims, 0);
  std::copy(query.values.begin(), query.values.end(), q.begin());
  int64_t query_sum = 0;
  for (int8_t v : query.values) query_sum += v;
  const int32_t offset = static_cast<int32_t>(8 * query_sum);
  auto dot = &DotNibblesScalar;
#if defined(__x86_64__) && defined(__GNUC__)
  if (HasAvx2()) dot = &DotNibblesAvx2;
#endif
  const size_t stride = packed_bytes();
  for (size_t slot = 0; slot < scales_.size(); ++slot) {
    if (scales_[slot] == 0) continue;
    const int32_t d = dot(q.data(), codes_.data() + slot * stride, blocks_) - offset;
    out[slot] = static_cast<float>(d) * query.scale * scales_[slot];
  }
  return out;
}

std::vector<std::pair<float, uint32_t>> TopSimilar(const std::vector<float>& similarities, int k) {
  std::vector<std::pair<float, uint32_t>> ranked;
  ranked.reserve(similarities.size());
  for (uint32_t s = 0; s < similarities.size(); ++s) ranked.emplace_back(similarities[s], s);
  const size_t n = std::min<size_t>(std::max(0, k), ranked.size());
  auto better = [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  };
  std::partial_sort(ranked.begin(), ranked.begin() + n, ranked.end(), better);
  ranked.resize(n);
  return ranked;
}

}  // namespace waymark::crossing

#include "server/crossing/global_index.h"

#include <algorithm>
#include <cmath>
#include <cstring>

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
  codes_.clear();
  scales_.clear();
}

void GlobalIndex::Set(uint32_t slot, const GlobalCode& code) {
  if (slot >= scales_.size()) {
    scales_.resize(slot + 1, 0.f);
    codes_.resize(scales_.size() * static_cast<size_t>(dims_), 0);
  }
  if (static_cast<int>(code.values.size()) != dims_) {
    scales_[slot] = 0;
    return;
  }
  std::copy(code.values.begin(), code.values.end(), codes_.begin() + size_t(slot) * dims_);
  scales_[slot] = code.scale;
}

size_t GlobalIndex::coded() const {
  return static_cast<size_t>(std::count_if(scales_.begin(), scales_.end(),
                                           [](float s) { return s != 0; }));
}

GlobalCode GlobalIndex::Get(uint32_t slot) const {
  GlobalCode code;
  if (slot >= scales_.size() || scales_[slot] == 0) return code;
  const auto first = codes_.begin() + size_t(slot) * dims_;
  code.values.assign(first, first + dims_);
  code.scale = scales_[slot];
  return code;
}

namespace {

// The scan's inner loop. On x86-64 GCC also builds an AVX2 clone and the loader picks it on CPUs
// that have it (16 multiply-adds per instruction instead of SSE2's 8); the code stays portable.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
int32_t DotInt8(const int8_t* a, const int8_t* b, int n) {
  int32_t dot = 0;
  for (int i = 0; i < n; ++i) dot += int32_t(a[i]) * int32_t(b[i]);
  return dot;
}

}  // namespace

std::vector<float> GlobalIndex::Similarities(const GlobalCode& query) const {
  std::vector<float> out(scales_.size(), 0.f);
  if (static_cast<int>(query.values.size()) != dims_ || query.scale == 0) return out;
  const int8_t* q = query.values.data();
  for (size_t slot = 0; slot < scales_.size(); ++slot) {
    if (scales_[slot] == 0) continue;
    const int8_t* v = codes_.data() + slot * dims_;
    const int32_t dot = DotInt8(q, v, dims_);
    out[slot] = static_cast<float>(dot) * query.scale * scales_[slot];
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

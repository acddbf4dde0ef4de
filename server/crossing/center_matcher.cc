#include "server/crossing/center_matcher.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "server/crossing/features.h"
#include "server/crossing/l2_distance.h"

namespace waymark::crossing {
namespace {

// Centre descriptors are padded to a multiple of this (a vector of floats) so the kernel below has
// no scalar tail.
constexpr uint32_t kLanes = 16;
// The basis is refitted each time the centres' descriptors double, until it was fitted on this
// many (a sample of them; more would not change the basis much, only cost the re-projection).
constexpr size_t kFitSample = 4096;

// kLanes floats as one value: GCC lowers it to the widest vectors of the clone being compiled
// (one AVX-512 register, two AVX2 ones, four SSE ones); written out because the auto-vectorizer
// turned the same loop into sixteen scalar sums.
// (-Wpsabi warns that such a vector passed by value would change the ABI across clones; none is:
// LoadLanes is always inlined.)
#pragma GCC diagnostic ignored "-Wpsabi"
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));
using LaneMask = int32_t __attribute__((vector_size(kLanes * sizeof(int32_t))));

// Always inlined: a vector returned by a real call would need an ABI for its width.
__attribute__((always_inline)) inline Lanes LoadLanes(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Appends to `hits` the descriptors of a centre whose projected squared distance to the query is
// under their threshold scale * s(x)^2 + slack. The distance is taken as |q|^2 + |x|^2 - 2 q.x
// (one multiply-add per dimension; `minus_twice_query` holds -2 q), kLanes descriptors at a time
// with their sums in registers over all dimensions. Most queries have no hit in a centre, so the
// lanes' verdicts are OR-ed across the centre and looked at once; only a centre with a hit is
// gone over again to list them. The crossing library is built for any x86-64; the loader picks
// the AVX-512 or AVX2 clone where the CPU has it.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void ProjectedHits(const float* minus_twice_query, float query_norm, const float* projected,
                   const float* norms, const float* neighbour_sq, uint32_t padded, float scale,
                   float slack, std::vector<uint32_t>* hits) {
  const auto below = [&](uint32_t first) {
    Lanes sum = LoadLanes(norms + first) + query_norm;
    for (int j = 0; j < CenterMatcher::kDims; ++j) {
      sum += minus_twice_query[j] * LoadLanes(projected + static_cast<size_t>(j) * padded + first);
    }
    return sum < LoadLanes(neighbour_sq + first) * scale + slack;
  };
  LaneMask any = {};
  for (uint32_t first = 0; first < padded; first += kLanes) any |= below(first);
  int32_t found = 0;
  for (uint32_t l = 0; l < kLanes; ++l) found |= any[l];
  if (found == 0) return;
  for (uint32_t first = 0; first < padded; first += kLanes) {
    const LaneMask lanes = below(first);
    for (uint32_t l = 0; l < kLanes; ++l) {
      if (lanes[l] != 0) hits->push_back(first + l);
    }
  }
}

// The descriptors of a span as a count x 128 CV_64F matrix (rows of the store may sit in two
// blocks, so row by row).
cv::Mat AsDoubles(const DescriptorStore& store, ViewSpan span) {
  cv::Mat out(static_cast<int>(span.count), kDescriptorSize, CV_64F);
  for (uint32_t i = 0; i < span.count; ++i) {
    const uint8_t* d = store.Get(span.first + i);
    double* row = out.ptr<double>(static_cast<int>(i));
    for (int k = 0; k < kDescriptorSize; ++k) row[k] = d[k];
  }
  return out;
}

}  // namespace

void CenterMatcher::Add(ViewSpan span) {
  Center center;
  center.span = span;
  center.padded = (span.count + kLanes - 1) / kLanes * kLanes;
  center.neighbour_sq.assign(center.padded, 0.0f);
  // s(x)^2, exact: each descriptor's nearest other descriptor in the centre.
  for (uint32_t i = 0; i < span.count; ++i) {
    int32_t nearest = std::numeric_limits<int32_t>::max();
    for (uint32_t j = 0; j < span.count; ++j) {
      if (j != i) nearest = std::min(nearest, SquaredL2(store_.Get(span.first + i),
                                                        store_.Get(span.first + j)));
    }
    if (span.count >= 2) center.neighbour_sq[i] = static_cast<float>(nearest);
  }
  centers_.push_back(std::move(center));
  descriptors_ += span.count;
  if (basis_.empty() || (fitted_on_ < kFitSample && descriptors_ >= 2 * fitted_on_)) {
    Refit();
  } else {
    Project(&centers_.back());
  }
}

void CenterMatcher::Clear() {
  centers_.clear();
  basis_.release();
  descriptors_ = 0;
  fitted_on_ = 0;
}

void CenterMatcher::Refit() {
  // An evenly strided sample over all centres' descriptors (deterministic).
  const size_t step = std::max<size_t>(1, descriptors_ / kFitSample);
  cv::Mat sample;
  size_t seen = 0;
  for (const Center& c : centers_) {
    for (uint32_t i = 0; i < c.span.count; ++i, ++seen) {
      if (seen % step == 0) sample.push_back(AsDoubles(store_, ViewSpan{c.span.first + i, 1}));
    }
  }
  basis_ = cv::Mat::eye(kDims, kDescriptorSize, CV_64F);  // any orthonormal rows will do
  if (sample.rows >= 2) {
    cv::Mat covariance, mean, eigenvalues, eigenvectors;
    cv::calcCovarMatrix(sample, covariance, mean,
                        cv::COVAR_NORMAL | cv::COVAR_ROWS | cv::COVAR_SCALE, CV_64F);
    // Symmetric eigen decomposition: 128 orthonormal eigenvectors, largest eigenvalue first.
    if (cv::eigen(covariance, eigenvalues, eigenvectors)) {
      basis_ = eigenvectors.rowRange(0, kDims).clone();
    }
  }
  fitted_on_ = descriptors_;
  for (Center& c : centers_) Project(&c);
}

void CenterMatcher::Project(Center* center) const {
  center->projected.assign(static_cast<size_t>(kDims) * center->padded, 0.0f);
  center->norms.assign(center->padded, 0.0f);
  if (center->span.count == 0) return;
  // In double, then rounded once to float: the rounding is what the thresholds' slack covers.
  const cv::Mat projected = AsDoubles(store_, center->span) * basis_.t();  // count x kDims
  for (uint32_t i = 0; i < center->span.count; ++i) {
    const double* row = projected.ptr<double>(static_cast<int>(i));
    for (int j = 0; j < kDims; ++j) {
      center->projected[static_cast<size_t>(j) * center->padded + i] = static_cast<float>(row[j]);
    }
    double norm = 0;
    for (int j = 0; j < kDims; ++j) norm += row[j] * row[j];
    center->norms[i] = static_cast<float>(norm);
  }
}

std::vector<int> CenterMatcher::CountMatches(const cv::Mat& query, double ratio) const {
  std::vector<int> counts(centers_.size(), 0);
  if (centers_.empty() || query.rows == 0) return counts;
  // A match needs d(q, x)^2 < (lambda / (1 - lambda))^2 s(x)^2 (header). The threshold is widened
  // by 0.1 % + 16 (squared units), far beyond the float rounding of the projected distances (below
  // 1 at these magnitudes) and of the threshold itself: widening only lets more pairs reach the
  // exact test. With lambda = 1 there is no ball: every query descriptor is matched exactly.
  const bool balls = ratio < 1.0;
  const double factor = balls ? ratio / (1.0 - ratio) : 0.0;
  const float scale = static_cast<float>(factor * factor * 1.001);
  constexpr float kSlack = 16.0f;

  cv::Mat query_double;
  query.convertTo(query_double, CV_64F);
  const cv::Mat projected = query_double * basis_.t();  // rows x kDims
  cv::Mat minus_twice;  // -2 q per row, float, as the kernel takes it
  projected.convertTo(minus_twice, CV_32F, -2.0);
  std::vector<float> norms(query.rows);
  for (int r = 0; r < query.rows; ++r) norms[r] = static_cast<float>(projected.row(r).dot(projected.row(r)));

  // The centres are independent: on OpenCV's worker threads (a busy server runs them inline), each
  // range writing only its own counts, so the counts do not depend on the threads. The clustering
  // of one view waits for the previous one's, so it is enrollment's serial stage.
  cv::parallel_for_(cv::Range(0, static_cast<int>(centers_.size())), [&](const cv::Range& range) {
    std::vector<uint32_t> hits;
    for (int c = range.start; c < range.end; ++c) {
      const Center& center = centers_[c];
      if (center.span.count < 2) continue;  // no second neighbour: nothing matches (MatchViewExact)
      for (int r = 0; r < query.rows; ++r) {
        const uint8_t* q = query.ptr<uint8_t>(r);
        bool inside = !balls;
        if (balls) {
          hits.clear();
          ProjectedHits(minus_twice.ptr<float>(r), norms[r], center.projected.data(),
                        center.norms.data(), center.neighbour_sq.data(), center.padded, scale,
                        kSlack, &hits);
          for (uint32_t i : hits) {
            if (i >= center.span.count) continue;  // padding
            const float threshold = scale * center.neighbour_sq[i] + kSlack;
            if (static_cast<float>(SquaredL2(q, store_.Get(center.span.first + i))) < threshold) {
              inside = true;
              break;
            }
          }
        }
        if (!inside) continue;
        const TwoNearest best = FindTwoNearest(q, store_, center.span);
        if (PassesRatio(best.first, best.second, ratio)) ++counts[c];
      }
    }
  });
  return counts;
}

size_t CenterMatcher::memory_bytes() const {
  size_t bytes = basis_.total() * basis_.elemSize();
  for (const Center& c : centers_) {
    bytes += sizeof(Center) +
             (c.projected.capacity() + c.norms.capacity() + c.neighbour_sq.capacity()) * sizeof(float);
  }
  return bytes;
}

}  // namespace waymark::crossing

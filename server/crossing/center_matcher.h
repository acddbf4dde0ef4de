#ifndef WAYMARK_SERVER_CROSSING_CENTER_MATCHER_H_
#define WAYMARK_SERVER_CROSSING_CENTER_MATCHER_H_

// The clustering's matcher (METHODS.md section 1): the ratio-test match count of a new view against
// every cluster centre, exactly as MatchViewExact counts it, without comparing every query
// descriptor with every centre descriptor at full length.
//
// Why it can skip pairs and stay exact: if q's nearest descriptor in a centre is x and its second
// nearest is at dis_b, then dis_b <= d(q, m) <= d(q, x) + s(x), where m is x's own nearest
// neighbour inside the centre and s(x) = d(x, m). The ratio test dis_a < lambda * dis_b therefore
// implies d(q, x) < lambda / (1 - lambda) * s(x) (about 0.47 s(x) at lambda = 0.32): q can only
// match the centre from inside one of these balls around its descriptors. Whether q lies in a ball
// is first checked on a low-dimensional orthonormal projection of the descriptors (a projection
// never lengthens a distance, so it can only let a pair through, never lose one), then on the full
// descriptor; only a query descriptor inside a ball is matched against the centre exactly. The
// projection is a PCA basis of the centres' descriptors: it only decides how many pairs are
// rejected early, never a count.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "server/crossing/descriptor_store.h"
#include "server/crossing/view_matching.h"

namespace waymark::crossing {

class CenterMatcher {
 public:
  // Dimensions of the projection: 16 keep about half of SIFT's variance, enough that few pairs
  // outside the balls survive it, at an eighth of a full distance.
  static constexpr int kDims = 16;

  explicit CenterMatcher(const DescriptorStore& store) : store_(store) {}
  CenterMatcher(const CenterMatcher&) = delete;
  CenterMatcher& operator=(const CenterMatcher&) = delete;

  // Appends a centre (its descriptors must stay in the store).
  void Add(ViewSpan center);
  void Clear();

  // counts[c] = MatchViewExact(query, store, centre c, ratio).size(), centres in Add order.
  std::vector<int> CountMatches(const cv::Mat& query, double ratio) const;

  size_t size() const { return centers_.size(); }
  size_t memory_bytes() const;

 private:
  struct Center {
    ViewSpan span;
    uint32_t padded = 0;              // span.count rounded up to kLanes
    std::vector<float> projected;     // kDims x padded, dimension-major (padding 0)
    std::vector<float> norms;         // squared length of each projected descriptor
    std::vector<float> neighbour_sq;  // s(x)^2 per descriptor (padding 0: never inside a ball)
  };

  // A new PCA basis from a sample of the centres' descriptors, and every centre re-projected.
  void Refit();
  void Project(Center* center) const;

  const DescriptorStore& store_;
  std::vector<Center> centers_;
  cv::Mat basis_;          // kDims x 128, CV_64F, orthonormal rows
  size_t descriptors_ = 0;  // over all centres
  size_t fitted_on_ = 0;    // descriptors_ at the last Refit
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_CENTER_MATCHER_H_

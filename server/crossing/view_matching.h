#ifndef WAYMARK_SERVER_CROSSING_VIEW_MATCHING_H_
#define WAYMARK_SERVER_CROSSING_VIEW_MATCHING_H_

// Matching a query image against stored views with the ratio test of METHODS.md section 1:
// a query descriptor matches a view when its nearest neighbour in that view (distance dis_a) and
// the second nearest (dis_b) satisfy dis_a < ratio * dis_b. M = number of such query descriptors.

#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "server/crossing/descriptor_index.h"

namespace waymark::crossing {

// A view's descriptors: ids [first, first + count) of the DescriptorStore.
struct ViewSpan {
  uint32_t first = 0;
  uint32_t count = 0;
};

struct DescriptorMatch {
  int query_index;    // row of the query descriptor matrix
  uint32_t train_id;  // id in the DescriptorStore
};

using ViewMatches = std::unordered_map<uint32_t, std::vector<DescriptorMatch>>;  // by view slot

// The ratio test on squared distances: dis_a < ratio * dis_b  <=>  a2 < ratio^2 * b2.
inline bool PassesRatio(int64_t a2, int64_t b2, double ratio) {
  return static_cast<double>(a2) < ratio * ratio * static_cast<double>(b2);
}

// Nearest and second-nearest squared distances of `q` within a view, and the nearest's id
// (the exact search every ratio-test count here agrees with).
struct TwoNearest {
  int32_t first = std::numeric_limits<int32_t>::max();
  int32_t second = std::numeric_limits<int32_t>::max();
  uint32_t first_id = 0;
};
TwoNearest FindTwoNearest(const uint8_t* q, const DescriptorStore& store, ViewSpan view);

// Exact (brute-force) ratio-test matches of `query` (N x 128 CV_8U) against one view. A view with
// fewer than two descriptors has no second neighbour, so nothing matches it.
std::vector<DescriptorMatch> MatchViewExact(const cv::Mat& query, const DescriptorStore& store,
                                            ViewSpan view, double ratio);

// Ratio-test matches against every view at once through the global index: for each query
// descriptor the index returns its k nearest stored descriptors; a view seen twice among them has
// its dis_a and dis_b; a view seen once has dis_b >= the k-th distance, which decides most cases,
// and the rest are settled exactly against that view's descriptors (`resolve_exactly`), or
// dropped. Only views that `forests` indexes are matched (all views, or the cluster centres).
ViewMatches MatchAllViews(const cv::Mat& query, const ForestSet& forests,
                          const std::vector<ViewSpan>& spans, double ratio, bool resolve_exactly);
inline ViewMatches MatchAllViews(const cv::Mat& query, const DescriptorIndex& index,
                                 const std::vector<ViewSpan>& spans, double ratio,
                                 bool resolve_exactly) {
  return MatchAllViews(query, index.forests(), spans, ratio, resolve_exactly);
}

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_VIEW_MATCHING_H_

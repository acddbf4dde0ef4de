#include "server/crossing/view_matching.h"

#include <algorithm>
#include <limits>

#include "server/crossing/l2_distance.h"

namespace waymark::crossing {
namespace {

// The largest possible squared distance of two SIFT descriptors (unit vectors scaled to 512):
// an ambiguous view whose nearest is farther than ratio * this can never pass.
constexpr int64_t kMaxSquaredDistance = 2LL * 512 * 512;

}  // namespace

TwoNearest FindTwoNearest(const uint8_t* q, const DescriptorStore& store, ViewSpan view) {
  TwoNearest best;
  for (uint32_t id = view.first; id < view.first + view.count; ++id) {
    const int32_t d = SquaredL2(q, store.Get(id));
    if (d < best.first) {
      best.second = best.first;
      best.first = d;
      best.first_id = id;
    } else if (d < best.second) {
      best.second = d;
    }
  }
  return best;
}

std::vector<DescriptorMatch> MatchViewExact(const cv::Mat& query, const DescriptorStore& store,
                                            ViewSpan view, double ratio) {
  std::vector<DescriptorMatch> matches;
  if (view.count < 2) return matches;
  for (int i = 0; i < query.rows; ++i) {
    const TwoNearest best = FindTwoNearest(query.ptr<uint8_t>(i), store, view);
    if (PassesRatio(best.first, best.second, ratio)) {
      matches.push_back(DescriptorMatch{i, best.first_id});
    }
  }
  return matches;
}

ViewMatches MatchAllViews(const cv::Mat& query, const ForestSet& forests,
                          const std::vector<ViewSpan>& spans, double ratio, bool resolve_exactly) {
  ViewMatches result;
  const DescriptorStore& store = forests.store();
  KnnList knn(forests.options().knn);
  // Views seen in this descriptor's neighbour list, in order of their nearest (list is sorted).
  std::vector<uint32_t> seen_views;
  std::vector<const Neighbour*> seen_first, seen_second;
  for (int i = 0; i < query.rows; ++i) {
    const uint8_t* q = query.ptr<uint8_t>(i);
    knn.Clear();
    forests.Search(q, &knn);
    seen_views.clear();
    seen_first.clear();
    seen_second.clear();
    for (const Neighbour& n : knn.items()) {
      const uint32_t view = store.ViewOf(n.id);
      size_t k = 0;
      while (k < seen_views.size() && seen_views[k] != view) ++k;
      if (k == seen_views.size()) {
        seen_views.push_back(view);
        seen_first.push_back(&n);
        seen_second.push_back(nullptr);
      } else if (seen_second[k] == nullptr) {
        seen_second[k] = &n;
      }
    }
    // Beyond a full list every descriptor is at least as far as its last entry. A list that is
    // not full (a search that ended early, or a small set) bounds nothing: a view seen once in
    // it must be settled exactly.
    const bool bounded = knn.full();
    const int64_t beyond = bounded ? knn.worst() : 0;
    for (size_t k = 0; k < seen_views.size(); ++k) {
      const uint32_t view = seen_views[k];
      if (view >= spans.size() || spans[view].count < 2) continue;
      const int64_t a2 = seen_first[k]->squared_distance;
      uint32_t matched_id = seen_first[k]->id;
      bool accept;
      if (seen_second[k] != nullptr) {
        accept = PassesRatio(a2, seen_second[k]->squared_distance, ratio);
      } else if (bounded && PassesRatio(a2, beyond, ratio)) {
        accept = true;  // dis_b >= the k-th distance already makes it pass
      } else if (resolve_exactly && PassesRatio(a2, kMaxSquaredDistance, ratio)) {
        const TwoNearest exact = FindTwoNearest(q, store, spans[view]);
        accept = PassesRatio(exact.first, exact.second, ratio);
        matched_id = exact.first_id;
      } else {
        accept = false;
      }
      if (accept) result[view].push_back(DescriptorMatch{i, matched_id});
    }
  }
  return result;
}

}  // namespace waymark::crossing

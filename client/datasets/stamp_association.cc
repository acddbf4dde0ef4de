#include "client/datasets/stamp_association.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

namespace waymark::cli {

std::vector<PoseMatch> AssociateByStamp(const std::vector<double>& estimate_stamps,
                                        const std::vector<double>& groundtruth_stamps,
                                        double max_dt) {
  // Ground truth sorted by stamp, so each estimate's candidates are one window.
  std::vector<size_t> gt_order(groundtruth_stamps.size());
  std::iota(gt_order.begin(), gt_order.end(), 0);
  std::stable_sort(gt_order.begin(), gt_order.end(), [&](size_t a, size_t b) {
    return groundtruth_stamps[a] < groundtruth_stamps[b];
  });
  std::vector<double> gt_sorted;
  gt_sorted.reserve(gt_order.size());
  for (size_t i : gt_order) gt_sorted.push_back(groundtruth_stamps[i]);

  std::vector<std::tuple<double, size_t, size_t>> candidates;  // (|dt|, estimate, groundtruth)
  for (size_t e = 0; e < estimate_stamps.size(); ++e) {
    const double t = estimate_stamps[e];
    auto it = std::lower_bound(gt_sorted.begin(), gt_sorted.end(), t - max_dt);
    for (; it != gt_sorted.end() && *it <= t + max_dt; ++it) {
      const double dt = std::abs(*it - t);
      if (dt <= max_dt) {
        candidates.emplace_back(dt, e, gt_order[static_cast<size_t>(it - gt_sorted.begin())]);
      }
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> estimate_used(estimate_stamps.size(), false);
  std::vector<bool> gt_used(groundtruth_stamps.size(), false);
  std::vector<PoseMatch> matches;
  for (const auto& [dt, e, g] : candidates) {
    if (estimate_used[e] || gt_used[g]) continue;
    estimate_used[e] = true;
    gt_used[g] = true;
    matches.push_back({e, g});
  }
  std::sort(matches.begin(), matches.end(), [&](const PoseMatch& a, const PoseMatch& b) {
    if (estimate_stamps[a.estimate] != estimate_stamps[b.estimate]) {
      return estimate_stamps[a.estimate] < estimate_stamps[b.estimate];
    }
    return a.estimate < b.estimate;
  });
  return matches;
}

}  // namespace waymark::cli

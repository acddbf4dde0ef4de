#include "client/eval/relation_builder.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::cli {
namespace {

Relation Between(const StampedPose& a, const StampedPose& b) {
  return {a.stamp, b.stamp, Compose(Inverse(a.pose), b.pose)};
}

}  // namespace

BuiltRelations BuildRelations(const std::vector<StampedPose>& keyframes,
                              const RelationBuilderOptions& options) {
  BuiltRelations out;
  const int n = static_cast<int>(keyframes.size());
  for (int gap : options.gaps) {
    if (gap <= 0 || gap >= n) continue;
    const int pairs = n - gap;
    const int stride =
        gap == 1 ? 1 : std::max(1, (pairs + options.target_per_gap - 1) / options.target_per_gap);
    for (int i = 0; i + gap < n; i += stride) {
      out.relations.push_back(Between(keyframes[i], keyframes[i + gap]));
    }
  }
  out.sequential = static_cast<int>(out.relations.size());

  // Path length from the first keyframe, to tell a revisit from standing still.
  std::vector<double> travelled(n, 0.0);
  for (int i = 1; i < n; ++i) {
    travelled[i] = travelled[i - 1] + std::hypot(keyframes[i].pose.x - keyframes[i - 1].pose.x,
                                                 keyframes[i].pose.y - keyframes[i - 1].pose.y);
  }
  std::vector<std::pair<int, int>> candidates;  // (i, nearest j), by i
  const double radius2 = options.loop_radius_m * options.loop_radius_m;
  for (int i = 0; i < n; ++i) {
    int best = -1;
    double best_d2 = radius2;
    for (int j = i + std::max(1, options.loop_min_keyframes_apart); j < n; ++j) {
      if (travelled[j] - travelled[i] < options.loop_min_travel_m) continue;
      const double dx = keyframes[j].pose.x - keyframes[i].pose.x;
      const double dy = keyframes[j].pose.y - keyframes[i].pose.y;
      const double d2 = dx * dx + dy * dy;
      if (d2 <= best_d2 && (best < 0 || d2 < best_d2)) {
        best = j;
        best_d2 = d2;
      }
    }
    if (best >= 0) candidates.emplace_back(i, best);
  }
  out.loop_candidates = static_cast<int>(candidates.size());
  const size_t keep = std::min<size_t>(candidates.size(), std::max(0, options.max_loop_relations));
  for (size_t k = 0; k < keep; ++k) {
    // Evenly spread over the candidates (all of them when keep == size).
    const auto& [i, j] = candidates[k * candidates.size() / keep];
    out.relations.push_back(Between(keyframes[i], keyframes[j]));
  }
  out.loops = static_cast<int>(keep);
  return out;
}

std::string FormatRelations(const std::vector<Relation>& relations,
                            const std::vector<std::string>& header) {
  std::string text;
  for (const std::string& line : header) absl::StrAppend(&text, "# ", line, "\n");
  for (const Relation& r : relations) {
    absl::StrAppend(&text, absl::StrFormat("%.6f %.6f %.6f %.6f 0 0 0 %.6f\n", r.t1, r.t2,
                                           r.delta.x, r.delta.y, r.delta.theta));
  }
  return text;
}

}  // namespace waymark::cli

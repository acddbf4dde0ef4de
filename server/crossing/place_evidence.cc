#include "server/crossing/place_evidence.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace waymark::crossing {

absl::Status ValidateEvidenceOptions(const EvidenceOptions& o) {
  if (!(o.threshold >= 0 && o.threshold < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("evidence threshold = ", o.threshold, " must be in [0, 1)"));
  }
  if (!(o.switch_probability >= 0 && o.switch_probability <= 1)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "evidence switch_probability = ", o.switch_probability, " must be in [0, 1]"));
  }
  if (!(o.max_log10_ratio > 0 && o.max_log10_ratio <= 50)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "evidence max_log10_ratio = ", o.max_log10_ratio, " must be in (0, 50]"));
  }
  if (!(o.miss_log10_ratio >= -o.max_log10_ratio && o.miss_log10_ratio <= 0)) {
    return absl::InvalidArgumentError(absl::StrCat("evidence miss_log10_ratio = ",
                                                   o.miss_log10_ratio,
                                                   " must be in [-max_log10_ratio, 0]"));
  }
  return absl::OkStatus();
}

double PlaceEvidenceFilter::Posterior(int64_t crossing_id) const {
  const auto it = posterior_.find(crossing_id);
  return it == posterior_.end() ? 0.0 : it->second;
}

void PlaceEvidenceFilter::Reset() {
  posterior_.clear();
  unknown_ = 1.0;
  belief_ = PlaceBelief{};
}

const PlaceBelief& PlaceEvidenceFilter::Update(const std::vector<FrameEvidence>& evidence) {
  // Best evidence per crossing; a crossing seen for the first time enters with no mass yet (the
  // prediction gives it its share of the switch probability).
  std::map<int64_t, double> log_ratio;
  for (const FrameEvidence& e : evidence) {
    if (!std::isfinite(e.log10_nfa)) continue;
    // A candidate chance explains (NFA >= 1) says no more than a frame without one.
    const double r =
        std::clamp(-e.log10_nfa, options_.miss_log10_ratio, options_.max_log10_ratio);
    auto [it, inserted] = log_ratio.emplace(e.crossing_id, r);
    if (!inserted) it->second = std::max(it->second, r);
    posterior_.emplace(e.crossing_id, 0.0);
  }
  // Predict: the robot may have moved to any place (the unknown one included).
  const double places = static_cast<double>(posterior_.size()) + 1.0;
  const double s = options_.switch_probability;
  for (auto& [id, p] : posterior_) p = (1.0 - s) * p + s / places;
  unknown_ = (1.0 - s) * unknown_ + s / places;
  // Update in log space against the largest ratio (no overflow), then normalise.
  double top = 0.0;
  for (const auto& [id, r] : log_ratio) top = std::max(top, r);
  double total = unknown_ * std::pow(10.0, -top);
  for (auto& [id, p] : posterior_) {
    const auto it = log_ratio.find(id);
    p *= std::pow(10.0, (it == log_ratio.end() ? options_.miss_log10_ratio : it->second) - top);
    total += p;
  }
  if (total > 0) {
    for (auto& [id, p] : posterior_) p /= total;
    unknown_ = unknown_ * std::pow(10.0, -top) / total;
  }
  // The belief.
  const int64_t previous = belief_.crossing_id;
  int64_t best = -1;
  double best_p = 0.0;
  for (const auto& [id, p] : posterior_) {
    if (p > best_p) {
      best = id;
      best_p = p;
    }
  }
  ++belief_.frames;
  belief_.frames_since_change = best == previous ? belief_.frames_since_change + 1 : 0;
  belief_.crossing_id = best;
  belief_.posterior = best_p;
  belief_.unknown = unknown_;
  belief_.recognized = best >= 0 && best_p >= options_.threshold;
  return belief_;
}

}  // namespace waymark::crossing

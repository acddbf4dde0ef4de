#include "server/crossing/options.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace waymark::crossing {
namespace {

absl::Status Invalid(const std::string& message) { return absl::InvalidArgumentError(message); }

}  // namespace

absl::Status ValidateFeatureOptions(const FeatureOptions& o) {
  if (o.work_width < 32 || o.work_width > 4096 || o.work_height < 32 || o.work_height > 4096) {
    return Invalid(absl::StrCat("working resolution ", o.work_width, "x", o.work_height,
                                " is out of range: width and height must be in [32, 4096]"));
  }
  if (o.hue_bins < 2 || o.hue_bins > 360) {
    return Invalid(absl::StrCat("hue_bins = ", o.hue_bins, " is out of range: use 2..360"));
  }
  if (o.max_keypoints < 0) {
    return Invalid(absl::StrCat("max_keypoints = ", o.max_keypoints, " must be >= 0 (0 = no limit)"));
  }
  return absl::OkStatus();
}

absl::Status ValidateClusterOptions(const ClusterOptions& o) {
  if (o.threshold < 1) {
    return Invalid(absl::StrCat("cluster_threshold = ", o.threshold, " must be >= 1"));
  }
  if (!(o.ratio > 0 && o.ratio <= 1)) {
    return Invalid(absl::StrCat("cluster ratio = ", o.ratio, " must be in (0, 1]"));
  }
  return absl::OkStatus();
}

absl::Status ValidateRecognitionOptions(const RecognitionOptions& o) {
  if (o.mode != RecognitionMode::kPaper && o.mode != RecognitionMode::kVerified &&
      o.mode != RecognitionMode::kRetrieval) {
    return Invalid("mode must be PAPER, VERIFIED or RETRIEVAL");
  }
  if (!(o.ratio > 0 && o.ratio <= 1)) {
    return Invalid(absl::StrCat("ratio (lambda) = ", o.ratio, " must be in (0, 1]"));
  }
  if (!(o.verified_ratio > 0 && o.verified_ratio <= 1)) {
    return Invalid(absl::StrCat("verified_ratio = ", o.verified_ratio, " must be in (0, 1]"));
  }
  if (o.n0 < 1 || o.n1 < 1 || o.n2 < 1) {
    return Invalid(absl::StrCat("N0, N1, N2 must be >= 1 (got ", o.n0, ", ", o.n1, ", ", o.n2, ")"));
  }
  if (!(o.alpha >= 0 && o.alpha <= 1 && o.beta >= 0 && o.beta <= 1) ||
      std::fabs(o.alpha + o.beta - 1.0) > 1e-6) {
    return Invalid(absl::StrCat("alpha = ", o.alpha, " and beta = ", o.beta,
                                " must be in [0, 1] and sum to 1"));
  }
  if (o.min_inliers < 0) {
    return Invalid(absl::StrCat("min_inliers = ", o.min_inliers, " must be >= 0"));
  }
  if (!(o.min_inlier_share >= 0 && o.min_inlier_share <= 1)) {
    return Invalid(absl::StrCat("min_inlier_share = ", o.min_inlier_share, " must be in [0, 1]"));
  }
  if (!(o.ransac_threshold_px > 0 && o.ransac_threshold_px <= 50)) {
    return Invalid(absl::StrCat("ransac_threshold_px = ", o.ransac_threshold_px,
                                " must be in (0, 50]"));
  }
  if (!(o.max_log10_nfa >= -1e4 && o.max_log10_nfa <= 100)) {
    return Invalid(absl::StrCat("max_log10_nfa = ", o.max_log10_nfa, " must be in [-10000, 100]"));
  }
  if (!(o.evidence_threshold >= 0 && o.evidence_threshold < 1)) {
    return Invalid(absl::StrCat("evidence_threshold = ", o.evidence_threshold,
                                " must be in [0, 1)"));
  }
  if (o.shortlist < 1 || o.shortlist > 1000) {
    return Invalid(absl::StrCat("shortlist = ", o.shortlist, " must be in [1, 1000]"));
  }
  if (o.global_shortlist < 0 || o.global_shortlist > 1000) {
    return Invalid(
        absl::StrCat("global_shortlist = ", o.global_shortlist, " must be in [0, 1000]"));
  }
  if (!(o.max_log10_global_efa >= -1e4 && o.max_log10_global_efa <= 100)) {
    return Invalid(absl::StrCat("max_log10_global_efa = ", o.max_log10_global_efa,
                                " must be in [-10000, 100]"));
  }
  if (!(o.min_global_lift >= 0 && o.min_global_lift <= 2)) {
    return Invalid(
        absl::StrCat("min_global_lift = ", o.min_global_lift, " must be in [0, 2] (0 = off)"));
  }
  return absl::OkStatus();
}

}  // namespace waymark::crossing

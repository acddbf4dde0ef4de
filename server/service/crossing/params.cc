#include "server/service/crossing/params.h"

#include <google/protobuf/util/json_util.h>

#include "absl/strings/str_cat.h"

namespace waymark::service {
namespace {

using crossing::RecognitionMode;

absl::StatusOr<RecognitionMode> FromProtoMode(v1::RecognitionMode mode) {
  switch (mode) {
    case v1::RECOGNITION_MODE_PAPER:
      return RecognitionMode::kPaper;
    case v1::RECOGNITION_MODE_VERIFIED:
      return RecognitionMode::kVerified;
    case v1::RECOGNITION_MODE_RETRIEVAL:
      return RecognitionMode::kRetrieval;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "recognition mode ", static_cast<int>(mode),
          " is not known: use RECOGNITION_MODE_PAPER, _VERIFIED or _RETRIEVAL"));
  }
}

// Applies the set fields of `p` on top of `options`.
absl::Status Overlay(const v1::RecognitionParams& p, crossing::RecognitionOptions* options) {
  if (p.has_mode() && p.mode() != v1::RECOGNITION_MODE_UNSPECIFIED) {
    absl::StatusOr<RecognitionMode> mode = FromProtoMode(p.mode());
    if (!mode.ok()) return mode.status();
    options->mode = *mode;
  }
  if (p.has_ratio()) options->ratio = p.ratio();
  if (p.has_n0()) options->n0 = p.n0();
  if (p.has_n1()) options->n1 = p.n1();
  if (p.has_n2()) options->n2 = p.n2();
  if (p.has_alpha()) options->alpha = p.alpha();
  if (p.has_beta()) options->beta = p.beta();
  if (p.has_verified_ratio()) options->verified_ratio = p.verified_ratio();
  if (p.has_min_inliers()) options->min_inliers = p.min_inliers();
  if (p.has_min_inlier_share()) options->min_inlier_share = p.min_inlier_share();
  if (p.has_ransac_threshold_px()) options->ransac_threshold_px = p.ransac_threshold_px();
  if (p.has_shortlist()) options->shortlist = p.shortlist();
  if (p.has_max_log10_nfa()) options->max_log10_nfa = p.max_log10_nfa();
  if (p.has_evidence_threshold()) options->evidence_threshold = p.evidence_threshold();
  if (p.has_global_shortlist()) options->global_shortlist = p.global_shortlist();
  if (p.has_min_global_lift()) options->min_global_lift = p.min_global_lift();
  if (p.has_max_log10_global_efa()) options->max_log10_global_efa = p.max_log10_global_efa();
  return crossing::ValidateRecognitionOptions(*options);
}

void FillRecognition(const crossing::RecognitionOptions& o, v1::RecognitionParams* p) {
  p->set_mode(ToProtoMode(o.mode));
  p->set_ratio(o.ratio);
  p->set_n0(o.n0);
  p->set_n1(o.n1);
  p->set_n2(o.n2);
  p->set_alpha(o.alpha);
  p->set_beta(o.beta);
  p->set_verified_ratio(o.verified_ratio);
  p->set_min_inliers(o.min_inliers);
  p->set_min_inlier_share(o.min_inlier_share);
  p->set_ransac_threshold_px(o.ransac_threshold_px);
  p->set_shortlist(o.shortlist);
  p->set_max_log10_nfa(o.max_log10_nfa);
  p->set_evidence_threshold(o.evidence_threshold);
  p->set_global_shortlist(o.global_shortlist);
  p->set_min_global_lift(o.min_global_lift);
  p->set_max_log10_global_efa(o.max_log10_global_efa);
}

}  // namespace

v1::RecognitionMode ToProtoMode(RecognitionMode mode) {
  switch (mode) {
    case RecognitionMode::kVerified: return v1::RECOGNITION_MODE_VERIFIED;
    case RecognitionMode::kRetrieval: return v1::RECOGNITION_MODE_RETRIEVAL;
    case RecognitionMode::kPaper: break;
  }
  return v1::RECOGNITION_MODE_PAPER;
}

absl::StatusOr<v1::DatabaseParams> EffectiveDatabaseParams(const v1::DatabaseParams& requested) {
  DatabaseOptions o;
  if (requested.has_work_width()) o.features.work_width = requested.work_width();
  if (requested.has_work_height()) o.features.work_height = requested.work_height();
  if (requested.has_hue_bins()) o.features.hue_bins = requested.hue_bins();
  if (requested.has_max_keypoints()) o.features.max_keypoints = requested.max_keypoints();
  if (requested.has_keep_aspect()) o.features.keep_aspect = requested.keep_aspect();
  if (requested.has_root_sift()) o.features.root_sift = requested.root_sift();
  if (requested.has_cluster_threshold()) o.clustering.threshold = requested.cluster_threshold();
  if (absl::Status s = crossing::ValidateFeatureOptions(o.features); !s.ok()) return s;
  if (absl::Status s = crossing::ValidateClusterOptions(o.clustering); !s.ok()) return s;
  if (absl::Status s = Overlay(requested.recognition(), &o.recognition); !s.ok()) return s;

  v1::DatabaseParams effective;
  effective.set_work_width(o.features.work_width);
  effective.set_work_height(o.features.work_height);
  effective.set_hue_bins(o.features.hue_bins);
  effective.set_max_keypoints(o.features.max_keypoints);
  effective.set_keep_aspect(o.features.keep_aspect);
  effective.set_root_sift(o.features.root_sift);
  effective.set_global_descriptor(requested.has_global_descriptor()
                                      ? requested.global_descriptor()
                                      : o.recognition.mode == RecognitionMode::kRetrieval);
  effective.set_cluster_threshold(o.clustering.threshold);
  FillRecognition(o.recognition, effective.mutable_recognition());
  return effective;
}

DatabaseOptions ToDatabaseOptions(const v1::DatabaseParams& p) {
  DatabaseOptions o;
  o.features.work_width = p.work_width();
  o.features.work_height = p.work_height();
  o.features.hue_bins = p.hue_bins();
  o.features.max_keypoints = p.max_keypoints();
  o.features.keep_aspect = p.keep_aspect();
  o.features.root_sift = p.root_sift();
  o.features.global_descriptor = p.global_descriptor();
  o.clustering.threshold = p.cluster_threshold();
  // Stored params were validated when the database was created.
  Overlay(p.recognition(), &o.recognition).IgnoreError();
  return o;
}

absl::StatusOr<crossing::RecognitionOptions> ResolveRecognitionOptions(
    const crossing::RecognitionOptions& database_defaults, const v1::RecognitionParams& request) {
  crossing::RecognitionOptions options = database_defaults;
  if (absl::Status s = Overlay(request, &options); !s.ok()) return s;
  return options;
}

std::string ParamsToJson(const v1::DatabaseParams& params) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  // Cannot fail for a well-formed message without Any fields.
  (void)google::protobuf::util::MessageToJsonString(params, &json, options);
  return json;
}

absl::StatusOr<v1::DatabaseParams> ParamsFromJson(const std::string& json) {
  v1::DatabaseParams params;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &params);
  if (!status.ok()) {
    return absl::DataLossError(absl::StrCat("stored database params are unreadable: ",
                                            status.ToString()));
  }
  return EffectiveDatabaseParams(params);
}

}  // namespace waymark::service

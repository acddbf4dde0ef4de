#include "server/service/slam/visual_params.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "storage/sha256.h"

namespace waymark::service {

namespace vs = visual_slam;

namespace {

// Larger values than int holds are out of every range the engine validates; keep them out of
// range instead of letting them wrap.
int ClampToInt(uint64_t value) {
  return static_cast<int>(std::min<uint64_t>(value, std::numeric_limits<int>::max()));
}

// Only a summary for people: an unavailable digest is not an error.
std::string Sha256Hex(const std::string& bytes) {
  absl::StatusOr<std::string> digest = storage::Sha256(bytes);
  return digest.ok() ? storage::HexString(*digest) : "";
}

absl::Status CheckCamera(const v1::CameraIntrinsics& camera) {
  const struct {
    const char* name;
    double value;
  } focal[] = {{"camera.fx", camera.fx()}, {"camera.fy", camera.fy()}};
  for (const auto& f : focal) {
    if (!std::isfinite(f.value) || f.value <= 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(f.name, " must be a positive number of pixels, got ", f.value));
    }
  }
  if (!std::isfinite(camera.cx()) || !std::isfinite(camera.cy())) {
    return absl::InvalidArgumentError("camera.cx and camera.cy must be finite (pixels)");
  }
  const struct {
    const char* name;
    uint32_t value;
  } sides[] = {{"camera.width", camera.width()}, {"camera.height", camera.height()}};
  for (const auto& side : sides) {
    if (side.value < 16 || side.value > static_cast<uint32_t>(kMaxCameraSide)) {
      return absl::InvalidArgumentError(absl::StrCat(
          side.name, " must be in [16, ", kMaxCameraSide, "] pixels (the frames' size), got ",
          side.value));
    }
  }
  if (camera.distortion_size() > 5) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera.distortion has ", camera.distortion_size(),
        " coefficients; at most 5 (k1, k2, p1, p2, k3)"));
  }
  for (double k : camera.distortion()) {
    if (!std::isfinite(k)) {
      return absl::InvalidArgumentError("camera.distortion coefficients must be finite");
    }
  }
  return absl::OkStatus();
}

absl::Status CheckDetector(const v1::DetectorConfig& detector) {
  if (!v1::DetectorConfig::Kind_IsValid(detector.kind())) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.kind ", detector.kind(), " is unknown (DETECTOR_NONE, YOLO, HOG)"));
  }
  const bool darknet = !detector.model_cfg().empty() || !detector.model_weights().empty();
  const bool onnx = !detector.model_onnx().empty();
  if (detector.kind() != v1::DetectorConfig::YOLO) {
    if (darknet || onnx) {
      return absl::InvalidArgumentError(absl::StrCat(
          "detector.model_* bytes were sent but detector.kind is ",
          v1::DetectorConfig::Kind_Name(detector.kind()), ", which takes no model; set kind YOLO"));
    }
    return absl::OkStatus();
  }
  if (darknet && onnx) {
    return absl::InvalidArgumentError(
        "detector: send either model_cfg + model_weights (darknet) or model_onnx, not both");
  }
  if (!darknet && !onnx) {
    return absl::InvalidArgumentError(
        "detector.kind YOLO needs a model: model_cfg + model_weights (darknet) or model_onnx");
  }
  if (darknet && (detector.model_cfg().empty() || detector.model_weights().empty())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "detector: a darknet model needs both model_cfg and model_weights; got ",
        detector.model_cfg().empty() ? "no cfg" : "no weights"));
  }
  if (detector.has_confidence() &&
      !(std::isfinite(detector.confidence()) && detector.confidence() > 0 &&
        detector.confidence() <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.confidence must be in (0, 1], got ", detector.confidence()));
  }
  if (detector.has_nms_threshold() &&
      !(std::isfinite(detector.nms_threshold()) && detector.nms_threshold() > 0 &&
        detector.nms_threshold() <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("detector.nms_threshold must be in (0, 1], got ", detector.nms_threshold()));
  }
  return absl::OkStatus();
}

void AddModelFile(const char* role, const std::string& bytes, v1::DetectorConfig* detector) {
  if (bytes.empty()) return;
  v1::ModelFileSummary* file = detector->add_model_files();
  file->set_role(role);
  file->set_size(bytes.size());
  file->set_sha256(Sha256Hex(bytes));
}

vs::Preset PresetOf(const v1::VisualSlamConfig& config) {
  return config.preset() == v1::VisualSlamConfig::PRESET_PAPER ? vs::Preset::kPaper
                                                                : vs::Preset::kMeasuredBest;
}

vs::DynamicFilter FromProtoFilter(v1::VisualSlamConfig::DynamicFilter filter) {
  switch (filter) {
    case v1::VisualSlamConfig::FILTER_BOXES_ONLY:
      return vs::DynamicFilter::kBoxesOnly;
    case v1::VisualSlamConfig::FILTER_NONE:
      return vs::DynamicFilter::kNone;
    case v1::VisualSlamConfig::FILTER_PROVEN:
      return vs::DynamicFilter::kProven;
    default:
      return vs::DynamicFilter::kFull;
  }
}

v1::VisualSlamConfig::DynamicFilter ToProtoFilter(vs::DynamicFilter filter) {
  switch (filter) {
    case vs::DynamicFilter::kBoxesOnly:
      return v1::VisualSlamConfig::FILTER_BOXES_ONLY;
    case vs::DynamicFilter::kNone:
      return v1::VisualSlamConfig::FILTER_NONE;
    case vs::DynamicFilter::kProven:
      return v1::VisualSlamConfig::FILTER_PROVEN;
    case vs::DynamicFilter::kFull:
      break;
  }
  return v1::VisualSlamConfig::FILTER_FULL;
}

}  // namespace

absl::StatusOr<v1::VisualSlamConfig> EffectiveVisualConfig(const v1::VisualSlamConfig& config) {
  if (absl::Status s = CheckCamera(config.camera()); !s.ok()) return s;
  if (absl::Status s = CheckDetector(config.detector()); !s.ok()) return s;
  if (!v1::VisualSlamConfig::Preset_IsValid(config.preset())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "preset ", config.preset(), " is unknown (PRESET_MEASURED_BEST, PRESET_PAPER)"));
  }
  if (!v1::VisualSlamConfig::DynamicFilter_IsValid(config.filter())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "filter ", config.filter(),
        " is unknown (FILTER_FULL, FILTER_BOXES_ONLY, FILTER_NONE, FILTER_PROVEN)"));
  }
  v1::VisualSlamConfig out = config;
  if (!out.has_depth_scale()) out.set_depth_scale(kDefaultDepthScale);
  v1::DetectorConfig* detector = out.mutable_detector();
  detector->clear_model_files();  // the server's summary, never the client's
  if (detector->kind() == v1::DetectorConfig::YOLO) {
    const vs::YoloOptions yolo;
    if (detector->movable_classes().empty()) {
      for (const std::string& name : yolo.movable_classes) detector->add_movable_classes(name);
    }
    if (!detector->has_confidence()) detector->set_confidence(yolo.confidence);
    if (!detector->has_nms_threshold()) detector->set_nms_threshold(yolo.nms);
    if (!detector->has_input_size()) detector->set_input_size(static_cast<uint32_t>(yolo.input_size));
    AddModelFile("cfg", detector->model_cfg(), detector);
    AddModelFile("weights", detector->model_weights(), detector);
    AddModelFile("onnx", detector->model_onnx(), detector);
  }
  const vs::VisualOdometryOptions d = vs::OptionsForPreset(PresetOf(out));
  if (!out.has_filter()) out.set_filter(ToProtoFilter(d.filter));
  v1::VisualSlamParams* p = out.mutable_params();
  if (!p->has_delta()) p->set_delta(d.delta);
  if (!p->has_match_ratio()) p->set_match_ratio(d.match_ratio);
  if (!p->has_static_distance_px()) p->set_static_distance_px(d.static_distance_px);
  if (!p->has_inlier_threshold_px()) p->set_inlier_threshold_px(d.inlier_threshold_px);
  if (!p->has_orb_features()) p->set_orb_features(d.orb.features);
  if (!p->has_orb_scale_factor()) p->set_orb_scale_factor(d.orb.scale_factor);
  if (!p->has_orb_levels()) p->set_orb_levels(d.orb.levels);
  if (!p->has_orb_fast_threshold()) p->set_orb_fast_threshold(d.orb.fast_threshold);
  if (!p->has_b1()) p->set_b1(d.sampler.b1);
  if (!p->has_b2()) p->set_b2(d.sampler.b2);
  if (!p->has_lambda1()) p->set_lambda1(d.sampler.lambda1);
  if (!p->has_lambda2()) p->set_lambda2(d.sampler.lambda2);
  if (!p->has_tie_break_fraction()) p->set_tie_break_fraction(d.sampler.tie_break_fraction);
  if (!p->has_max_rounds()) p->set_max_rounds(d.sampler.max_rounds);
  if (!p->has_hypotheses_per_round()) p->set_hypotheses_per_round(d.sampler.hypotheses_per_round);
  if (!p->has_seed()) p->set_seed(d.sampler.seed);
  if (!p->has_min_depth()) p->set_min_depth(d.min_depth);
  if (!p->has_max_depth()) p->set_max_depth(d.max_depth);
  if (!p->has_min_tracked()) p->set_min_tracked(d.min_tracked);
  if (!p->has_keyframe_tracked_fraction()) p->set_keyframe_tracked_fraction(d.keyframe_tracked_fraction);
  if (!p->has_keyframe_distance()) p->set_keyframe_distance(d.keyframe_distance);
  if (!p->has_keyframe_angle()) p->set_keyframe_angle(d.keyframe_angle);
  if (!p->has_local_map_keyframes()) p->set_local_map_keyframes(d.local_map_keyframes);
  if (!p->has_static_hamming_fraction()) p->set_static_hamming_fraction(d.static_hamming_fraction);
  if (!p->has_proven_static_frames()) p->set_proven_static_frames(d.proven_static_frames);
  if (!p->has_prior_direction_deg()) p->set_prior_direction_deg(d.prior_direction_deg);
  if (!p->has_prior_rotation_deg()) p->set_prior_rotation_deg(d.prior_rotation_deg);
  if (!p->has_prior_inlier_fraction()) p->set_prior_inlier_fraction(d.prior_inlier_fraction);
  // The measured best's window depends on the input kind (monocular 10, RGB-D none), which the
  // first frame tells: unset says "by input kind".
  if (!p->has_bundle_window() && !d.bundle_monocular_only) p->set_bundle_window(d.bundle_window);
  if (!p->has_bundle_wait()) p->set_bundle_wait(d.bundle_wait);
  if (!p->has_relocalization_keyframes()) {
    p->set_relocalization_keyframes(static_cast<uint32_t>(d.relocalization_keyframes));
  }
  // The engine's own validation names the option; the whole conversion runs once here so that a
  // config that is stored is one that loads.
  absl::StatusOr<VisualSessionOptions> options = ToVisualSessionOptions(out);
  if (!options.ok()) return options.status();
  return out;
}

absl::StatusOr<VisualSessionOptions> ToVisualSessionOptions(const v1::VisualSlamConfig& config) {
  if (absl::Status s = CheckCamera(config.camera()); !s.ok()) return s;
  if (absl::Status s = CheckDetector(config.detector()); !s.ok()) return s;
  VisualSessionOptions options;
  vs::CameraModel& camera = options.camera;
  camera.fx = config.camera().fx();
  camera.fy = config.camera().fy();
  camera.cx = config.camera().cx();
  camera.cy = config.camera().cy();
  for (int i = 0; i < config.camera().distortion_size(); ++i) {
    camera.distortion[static_cast<size_t>(i)] = config.camera().distortion(i);
  }
  camera.width = static_cast<int>(config.camera().width());
  camera.height = static_cast<int>(config.camera().height());

  vs::VisualOdometryOptions& o = options.odometry;
  o = vs::OptionsForPreset(PresetOf(config));
  if (config.has_filter()) {
    o.filter = FromProtoFilter(config.filter());
  } else if (config.params().has_delta()) {
    // An effective config stored before presets existed (every param filled in, the filter a
    // plain proto3 field that FILTER_FULL left off the wire): the paper's filter, as it ran then.
    o.filter = vs::DynamicFilter::kFull;
  }
  if (config.has_depth_scale()) o.depth_scale = config.depth_scale();
  const v1::VisualSlamParams& p = config.params();
  if (p.has_delta()) o.delta = ClampToInt(p.delta());
  if (p.has_match_ratio()) o.match_ratio = p.match_ratio();
  if (p.has_static_distance_px()) o.static_distance_px = p.static_distance_px();
  if (p.has_inlier_threshold_px()) o.inlier_threshold_px = p.inlier_threshold_px();
  if (p.has_orb_features()) o.orb.features = ClampToInt(p.orb_features());
  if (p.has_orb_scale_factor()) o.orb.scale_factor = static_cast<float>(p.orb_scale_factor());
  if (p.has_orb_levels()) o.orb.levels = ClampToInt(p.orb_levels());
  if (p.has_orb_fast_threshold()) o.orb.fast_threshold = ClampToInt(p.orb_fast_threshold());
  if (p.has_b1()) o.sampler.b1 = p.b1();
  if (p.has_b2()) o.sampler.b2 = p.b2();
  if (p.has_lambda1()) o.sampler.lambda1 = p.lambda1();
  if (p.has_lambda2()) o.sampler.lambda2 = p.lambda2();
  if (p.has_tie_break_fraction()) o.sampler.tie_break_fraction = p.tie_break_fraction();
  if (p.has_max_rounds()) o.sampler.max_rounds = ClampToInt(p.max_rounds());
  if (p.has_hypotheses_per_round()) o.sampler.hypotheses_per_round = ClampToInt(p.hypotheses_per_round());
  if (p.has_seed()) o.sampler.seed = p.seed();
  if (p.has_min_depth()) o.min_depth = p.min_depth();
  if (p.has_max_depth()) o.max_depth = p.max_depth();
  if (p.has_min_tracked()) o.min_tracked = ClampToInt(p.min_tracked());
  if (p.has_keyframe_tracked_fraction()) o.keyframe_tracked_fraction = p.keyframe_tracked_fraction();
  if (p.has_keyframe_distance()) o.keyframe_distance = p.keyframe_distance();
  if (p.has_keyframe_angle()) o.keyframe_angle = p.keyframe_angle();
  if (p.has_local_map_keyframes()) o.local_map_keyframes = ClampToInt(p.local_map_keyframes());
  if (p.has_static_hamming_fraction()) o.static_hamming_fraction = p.static_hamming_fraction();
  if (p.has_proven_static_frames()) o.proven_static_frames = ClampToInt(p.proven_static_frames());
  if (p.has_prior_direction_deg()) o.prior_direction_deg = p.prior_direction_deg();
  if (p.has_prior_rotation_deg()) o.prior_rotation_deg = p.prior_rotation_deg();
  if (p.has_prior_inlier_fraction()) o.prior_inlier_fraction = p.prior_inlier_fraction();
  if (p.has_bundle_window()) {
    o.bundle_window = ClampToInt(p.bundle_window());
    o.bundle_monocular_only = false;  // asked for: on every input kind
  }
  if (p.has_bundle_wait()) o.bundle_wait = p.bundle_wait();
  if (p.has_relocalization_keyframes()) {
    o.relocalization_keyframes = ClampToInt(p.relocalization_keyframes());
  }
  if (absl::Status s = o.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("params.", s.message()));
  }

  const v1::DetectorConfig& detector = config.detector();
  vs::DetectorChoice& choice = options.detector;
  switch (detector.kind()) {
    case v1::DetectorConfig::YOLO: {
      choice.kind = vs::DetectorChoice::kYolo;
      choice.yolo.cfg = detector.model_cfg();
      choice.yolo.weights = detector.model_weights();
      choice.yolo.onnx = detector.model_onnx();
      if (!detector.class_names().empty()) {
        choice.yolo.class_names.assign(detector.class_names().begin(),
                                       detector.class_names().end());
      }
      if (!detector.movable_classes().empty()) {
        choice.yolo.movable_classes.assign(detector.movable_classes().begin(),
                                           detector.movable_classes().end());
      }
      if (detector.has_confidence()) choice.yolo.confidence = detector.confidence();
      if (detector.has_nms_threshold()) choice.yolo.nms = detector.nms_threshold();
      if (detector.has_input_size()) choice.yolo.input_size = ClampToInt(detector.input_size());
      break;
    }
    case v1::DetectorConfig::HOG:
      choice.kind = vs::DetectorChoice::kHog;
      break;
    default:
      choice.kind = vs::DetectorChoice::kNone;
  }
  return options;
}

v1::VisualSlamConfig EchoVisualConfig(v1::VisualSlamConfig config) {
  config.mutable_detector()->clear_model_cfg();
  config.mutable_detector()->clear_model_weights();
  config.mutable_detector()->clear_model_onnx();
  return config;
}

v1::Pose3D ToProtoPose3D(const vs::Pose& pose) {
  Eigen::Quaterniond q(pose.R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;  // one of the two equal quaternions: qw >= 0
  v1::Pose3D out;
  out.set_x(pose.t.x());
  out.set_y(pose.t.y());
  out.set_z(pose.t.z());
  out.set_qx(q.x());
  out.set_qy(q.y());
  out.set_qz(q.z());
  out.set_qw(q.w());
  return out;
}

vs::Pose FromProtoPose3D(const v1::Pose3D& pose) {
  Eigen::Quaterniond q(pose.qw(), pose.qx(), pose.qy(), pose.qz());
  vs::Pose out;
  if (q.norm() > 0) out.R = q.normalized().toRotationMatrix();
  out.t = Eigen::Vector3d(pose.x(), pose.y(), pose.z());
  return out;
}

absl::StatusOr<vs::Box> FromProtoBox(const v1::BoundingBox& box) {
  if (!std::isfinite(box.x()) || !std::isfinite(box.y()) || !std::isfinite(box.width()) ||
      !std::isfinite(box.height()) || !std::isfinite(box.confidence())) {
    return absl::InvalidArgumentError("a box has a non-finite corner, size or confidence");
  }
  if (box.width() < 0 || box.height() < 0) {
    return absl::InvalidArgumentError(absl::StrCat("a box has a negative size (", box.width(),
                                                   " x ", box.height(), ")"));
  }
  vs::Box out;
  out.x = box.x();
  out.y = box.y();
  out.w = box.width();
  out.h = box.height();
  out.label = box.label();
  out.confidence = box.confidence();
  return out;
}

v1::BoundingBox ToProtoBox(const vs::Box& box) {
  v1::BoundingBox out;
  out.set_x(box.x);
  out.set_y(box.y);
  out.set_width(box.w);
  out.set_height(box.h);
  out.set_label(box.label);
  out.set_confidence(box.confidence);
  return out;
}

namespace {

v1::VisualFrameInfo::TrackingState ToProtoState(vs::TrackingState state) {
  switch (state) {
    case vs::TrackingState::kInitializing:
      return v1::VisualFrameInfo::INITIALIZING;
    case vs::TrackingState::kTracking:
      return v1::VisualFrameInfo::TRACKING;
    case vs::TrackingState::kLost:
      return v1::VisualFrameInfo::LOST;
  }
  return v1::VisualFrameInfo::TRACKING_STATE_UNSPECIFIED;
}

v1::VisualFrameInfo::FeatureLabel ToProtoLabel(vs::FeatureLabel label) {
  switch (label) {
    case vs::FeatureLabel::kStatic:
      return v1::VisualFrameInfo::STATIC;
    case vs::FeatureLabel::kStaticInBox:
      return v1::VisualFrameInfo::STATIC_IN_BOX;
    case vs::FeatureLabel::kDynamic:
      return v1::VisualFrameInfo::DYNAMIC;
    case vs::FeatureLabel::kPotentiallyDynamic:
      return v1::VisualFrameInfo::POTENTIALLY_DYNAMIC;
    case vs::FeatureLabel::kUnmatched:
      break;
  }
  return v1::VisualFrameInfo::UNMATCHED;
}

v1::VisualTrackingQuality::Level ToProtoQuality(vs::TrackingQuality::Level level) {
  switch (level) {
    case vs::TrackingQuality::Level::kInitializing:
      return v1::VisualTrackingQuality::INITIALIZING;
    case vs::TrackingQuality::Level::kGood:
      return v1::VisualTrackingQuality::GOOD;
    case vs::TrackingQuality::Level::kWeak:
      return v1::VisualTrackingQuality::WEAK;
    case vs::TrackingQuality::Level::kLost:
      return v1::VisualTrackingQuality::LOST;
  }
  return v1::VisualTrackingQuality::LEVEL_UNSPECIFIED;
}

uint32_t Count(int n) { return static_cast<uint32_t>(std::max(0, n)); }

}  // namespace

void FillVisualUpdate(const vs::FrameResult& result, bool want_features, double decode_ms,
                      double queue_ms, v1::SlamUpdate* update) {
  update->set_stamp(result.stamp);
  *update->mutable_pose3d() = ToProtoPose3D(result.pose);
  v1::VisualFrameInfo* info = update->mutable_visual();
  info->set_state(ToProtoState(result.state));
  info->set_keyframe(result.keyframe);
  v1::FeatureCounts* counts = info->mutable_counts();
  counts->set_total(Count(result.counts.total));
  counts->set_potentially_dynamic(Count(result.counts.potentially_dynamic));
  counts->set_matched(Count(result.counts.matched));
  counts->set_dynamic(Count(result.counts.dynamic));
  counts->set_tracked(Count(result.counts.tracked));
  counts->set_mapped(Count(result.counts.mapped));
  counts->set_proven(Count(result.counts.proven));
  info->set_relocalized(result.relocalized);
  v1::VisualTrackingQuality* quality = info->mutable_quality();
  quality->set_level(ToProtoQuality(result.quality.level));
  quality->set_inliers(Count(result.quality.inliers));
  quality->set_parallax_deg(result.quality.parallax_deg);
  quality->set_reason(result.quality.reason);
  for (const std::string& warning : result.warnings) info->add_warnings(warning);
  v1::VisualTimings* timings = info->mutable_timings();
  timings->set_decode_ms(decode_ms);
  timings->set_orb_ms(result.timings.orb_ms);
  timings->set_detector_ms(result.timings.detector_ms);
  timings->set_matching_ms(result.timings.matching_ms);
  timings->set_sampling_ms(result.timings.sampling_ms);
  timings->set_pose_ms(result.timings.pose_ms);
  timings->set_mapping_ms(result.timings.mapping_ms);
  timings->set_total_ms(result.timings.total_ms + decode_ms);
  timings->set_queue_ms(queue_ms);
  timings->set_bundle_ms(result.timings.bundle_ms);
  timings->set_bundle_wait_ms(result.timings.bundle_wait_ms);
  for (const vs::Box& box : result.boxes) *info->add_boxes() = ToProtoBox(box);
  if (want_features) {
    const size_t n = std::min(result.keypoints.size(), result.labels.size());
    info->mutable_feature_xy()->Reserve(static_cast<int>(2 * n));
    info->mutable_feature_labels()->Reserve(static_cast<int>(n));
    for (size_t i = 0; i < n; ++i) {
      info->add_feature_xy(result.keypoints[i].x);
      info->add_feature_xy(result.keypoints[i].y);
      info->add_feature_labels(ToProtoLabel(result.labels[i]));
    }
  }
}

}  // namespace waymark::service

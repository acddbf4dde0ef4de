#include "client/render/vo_frames.h"

#include <Eigen/Geometry>

namespace waymark::cli {

const char* VoFeatureLabelName(VoFeatureLabel label) {
  switch (label) {
    case VoFeatureLabel::kUnmatched:
      return "unmatched";
    case VoFeatureLabel::kStatic:
      return "static";
    case VoFeatureLabel::kStaticInBox:
      return "static in box";
    case VoFeatureLabel::kDynamic:
      return "dynamic";
    case VoFeatureLabel::kPotentiallyDynamic:
      return "potentially dynamic";
  }
  return "?";
}

namespace {

const char* StateName(v1::VisualFrameInfo::TrackingState state) {
  switch (state) {
    case v1::VisualFrameInfo::INITIALIZING:
      return "initializing";
    case v1::VisualFrameInfo::TRACKING:
      return "tracking";
    case v1::VisualFrameInfo::LOST:
      return "lost";
    default:
      return "unspecified";
  }
}

VoFeatureLabel LabelFromProto(int label) {
  switch (label) {
    case v1::VisualFrameInfo::STATIC:
      return VoFeatureLabel::kStatic;
    case v1::VisualFrameInfo::STATIC_IN_BOX:
      return VoFeatureLabel::kStaticInBox;
    case v1::VisualFrameInfo::DYNAMIC:
      return VoFeatureLabel::kDynamic;
    case v1::VisualFrameInfo::POTENTIALLY_DYNAMIC:
      return VoFeatureLabel::kPotentiallyDynamic;
    default:
      return VoFeatureLabel::kUnmatched;
  }
}

}  // namespace

StampedPose3 PoseFromProto(double stamp, const v1::Pose3D& pose) {
  StampedPose3 out;
  out.stamp = stamp;
  out.translation = Eigen::Vector3d(pose.x(), pose.y(), pose.z());
  Eigen::Quaterniond q(pose.qw(), pose.qx(), pose.qy(), pose.qz());
  // An unset pose (all zero) means identity rather than a degenerate rotation.
  out.rotation = q.norm() > 1e-9 ? q.normalized().toRotationMatrix() : Eigen::Matrix3d::Identity();
  return out;
}

static const char* QualityName(v1::VisualTrackingQuality::Level level) {
  switch (level) {
    case v1::VisualTrackingQuality::INITIALIZING: return "initializing";
    case v1::VisualTrackingQuality::GOOD: return "good";
    case v1::VisualTrackingQuality::WEAK: return "weak";
    case v1::VisualTrackingQuality::LOST: return "lost";
    default: return "";
  }
}

VoFrameRecord RecordFromUpdate(const v1::SlamUpdate& update, size_t index, double stamp) {
  VoFrameRecord record;
  record.index = index;
  record.stamp = stamp;
  record.answered = true;
  if (update.has_rejection()) {
    record.rejected = true;
    record.rejection_code = update.rejection().code();
    record.rejection_message = update.rejection().message();
    return record;
  }
  record.pose = PoseFromProto(stamp, update.pose3d());
  const v1::VisualFrameInfo& info = update.visual();
  record.state = StateName(info.state());
  record.keyframe = info.keyframe();
  const v1::FeatureCounts& c = info.counts();
  record.total = c.total();
  record.potentially_dynamic = c.potentially_dynamic();
  record.matched = c.matched();
  record.dynamic = c.dynamic();
  record.tracked = c.tracked();
  record.mapped = c.mapped();
  const v1::VisualTimings& t = info.timings();
  record.stage_ms = {t.decode_ms(),   t.orb_ms(),  t.detector_ms(), t.matching_ms(),
                     t.sampling_ms(), t.pose_ms(), t.mapping_ms(),  t.total_ms(),
                     t.bundle_wait_ms()};
  record.bundle_ms = t.bundle_ms();
  record.relocalized = info.relocalized();
  if (info.has_quality()) {
    record.quality = QualityName(info.quality().level());
    record.inliers = info.quality().inliers();
    record.parallax_deg = info.quality().parallax_deg();
    record.quality_reason = info.quality().reason();
  }
  record.warnings.assign(info.warnings().begin(), info.warnings().end());
  for (const v1::BoundingBox& b : info.boxes()) {
    record.boxes.push_back({b.x(), b.y(), b.width(), b.height(), b.label(), b.confidence()});
  }
  if (info.feature_xy_size() == 2 * info.feature_labels_size()) {
    record.features.reserve(info.feature_labels_size());
    for (int i = 0; i < info.feature_labels_size(); ++i) {
      record.features.push_back({info.feature_xy(2 * i), info.feature_xy(2 * i + 1),
                                 LabelFromProto(info.feature_labels(i))});
    }
  }
  return record;
}

}  // namespace waymark::cli

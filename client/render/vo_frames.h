#ifndef WAYMARK_CLIENT_RENDER_VO_FRAMES_H_
#define WAYMARK_CLIENT_RENDER_VO_FRAMES_H_

// What `waymark vo run` keeps of each frame's answer (a SlamUpdate of a visual session), in plain
// types so the pictures, the summary and their tests do not depend on the wire format.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "client/datasets/stamped_pose3.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// Colours of the feature pictures follow these labels (vo_pictures.h).
enum class VoFeatureLabel {
  kUnmatched,           // no match to the reference, or not tested
  kStatic,              // tracked and mapped
  kStaticInBox,         // inside a box but static: tracked, not mapped
  kDynamic,             // failed the static test: dropped
  kPotentiallyDynamic,  // inside a box, not tested
};
const char* VoFeatureLabelName(VoFeatureLabel label);

struct VoFeature {
  float x = 0;  // pixels
  float y = 0;
  VoFeatureLabel label = VoFeatureLabel::kUnmatched;
};

struct VoBox {
  float x = 0;  // top-left corner, pixels
  float y = 0;
  float w = 0;
  float h = 0;
  std::string label;
  float confidence = 0;
};

// Stages of the engine, in the order of VisualTimings (per-stage medians in the summary).
// bundle_wait: what the frame waited for a bundle adjustment (bundle_wait; 0 otherwise).
inline constexpr std::array<const char*, 9> kVoStages = {
    "decode", "orb", "detector", "matching", "sampling", "pose", "mapping", "total", "bundle_wait"};

struct VoFrameRecord {
  size_t index = 0;  // in the sequence as sent (0-based)
  double stamp = 0;
  bool answered = false;  // a SlamUpdate (or rejection) came back
  bool rejected = false;
  int rejection_code = 0;
  std::string rejection_message;
  std::string state;  // "initializing", "tracking", "lost"
  bool keyframe = false;
  StampedPose3 pose;
  // total, potentially_dynamic, matched, dynamic, tracked, mapped
  uint32_t total = 0;
  uint32_t potentially_dynamic = 0;
  uint32_t matched = 0;
  uint32_t dynamic = 0;
  uint32_t tracked = 0;
  uint32_t mapped = 0;
  bool relocalized = false;
  // VisualTrackingQuality: "initializing", "good", "weak", "lost" ("" from an older server).
  std::string quality;
  uint32_t inliers = 0;
  double parallax_deg = 0;
  std::string quality_reason;
  std::vector<std::string> warnings;  // the session's (VisualFrameInfo.warnings)
  double bundle_ms = 0;  // the bundle adjustment applied before this frame (background), 0 = none
  std::array<double, kVoStages.size()> stage_ms{};
  std::vector<VoBox> boxes;
  std::vector<VoFeature> features;  // only for frames that asked (want_features)
};

// The record of an update. A rejection keeps only the code and message. Per-feature data with a
// count that does not match the labels is dropped (it cannot be drawn faithfully).
VoFrameRecord RecordFromUpdate(const v1::SlamUpdate& update, size_t index, double stamp);

StampedPose3 PoseFromProto(double stamp, const v1::Pose3D& pose);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_VO_FRAMES_H_

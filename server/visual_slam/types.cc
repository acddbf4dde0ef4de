#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

const char* FeatureLabelName(FeatureLabel label) {
  switch (label) {
    case FeatureLabel::kUnmatched: return "unmatched";
    case FeatureLabel::kStatic: return "static";
    case FeatureLabel::kStaticInBox: return "static_in_box";
    case FeatureLabel::kDynamic: return "dynamic";
    case FeatureLabel::kPotentiallyDynamic: return "potentially_dynamic";
  }
  return "unknown";
}

const char* TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kInitializing: return "initializing";
    case TrackingState::kTracking: return "tracking";
    case TrackingState::kLost: return "lost";
  }
  return "unknown";
}

}  // namespace waymark::visual_slam

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

const char* QualityLevelName(TrackingQuality::Level level) {
  switch (level) {
    case TrackingQuality::Level::kInitializing: return "initializing";
    case TrackingQuality::Level::kGood: return "good";
    case TrackingQuality::Level::kWeak: return "weak";
    case TrackingQuality::Level::kLost: return "lost";
  }
  return "unknown";
}

}  // namespace waymark::visual_slam

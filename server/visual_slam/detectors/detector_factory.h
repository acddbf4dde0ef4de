#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_FACTORY_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_FACTORY_H_

// The session's choice of detector, built in one place so the service maps one config message.

#include <memory>

#include "absl/status/statusor.h"
#include "server/visual_slam/detectors/hog_people_detector.h"
#include "server/visual_slam/detectors/object_detector.h"
#include "server/visual_slam/detectors/yolo_detector.h"

namespace waymark::visual_slam {

struct DetectorChoice {
  enum Kind {
    kNone,  // no detector: only robot-supplied boxes split features
    kYolo,  // YoloOptions (the model bytes come with the choice)
    kHog,   // HogOptions (people only, no model)
  } kind = kNone;
  YoloOptions yolo;
  HogOptions hog;
};

// kNone gives a null pointer (VisualOdometry::Create accepts it); the others the detector or the
// INVALID_ARGUMENT of its Make function.
absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeDetector(const DetectorChoice& choice);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_FACTORY_H_

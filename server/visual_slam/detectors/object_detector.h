#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_OBJECT_DETECTOR_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_OBJECT_DETECTOR_H_

// Finds boxes of movable objects (people, cars, ...) in a frame: the "potentially dynamic" regions
// of eq 7. One interface, several detectors chosen per session (yolo_detector.h,
// hog_people_detector.h); "none" is a null detector pointer, and boxes supplied by the robot in a
// frame bypass the detector for that frame.

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

class ObjectDetector {
 public:
  virtual ~ObjectDetector() = default;
  // Boxes of movable classes in an 8-bit gray or BGR image, in its pixel coordinates, clipped
  // to the image. Not thread-safe: one session (one strand) calls it at a time.
  virtual absl::StatusOr<std::vector<Box>> Detect(const cv::Mat& image) = 0;
  // "yolo", "hog", ... for logs and SlamUpdates.
  virtual std::string name() const = 0;
};

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_OBJECT_DETECTOR_H_

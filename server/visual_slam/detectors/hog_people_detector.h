#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_HOG_PEOPLE_DETECTOR_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_HOG_PEOPLE_DETECTOR_H_

// People only, with no model to upload: OpenCV's HOG descriptor and its built-in linear SVM for
// upright pedestrians (Dalal & Triggs 2005, 64x128 window). A fallback for sessions without a
// YOLO model; it misses people who are sitting, cut by the frame edge or closer than about half
// the frame height, which YOLO finds.

#include <memory>

#include "absl/status/statusor.h"
#include "server/visual_slam/detectors/object_detector.h"

namespace waymark::visual_slam {

struct HogOptions {
  // SVM margin a window needs (OpenCV's default 0: the SVM's own decision boundary). Raise it to
  // trade recall for fewer false boxes.
  double hit_threshold = 0;
  // Window step in pixels (OpenCV's people-detector sample: 8, the HOG cell size).
  int win_stride = 8;
  // Pyramid step between scales (OpenCV's default 1.05).
  double scale = 1.05;
  // Overlapping windows a detection needs to survive grouping (OpenCV's default 2).
  int group_threshold = 2;
  // Frames wider than this are shrunk first (speed: the cost grows with the area); boxes are
  // returned in the original frame's pixels. 0 = never shrink.
  int max_width = 640;
};

// INVALID_ARGUMENT for a non-positive stride or max_width < 64 (the window), scale <= 1 or
// a negative group threshold.
absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeHogPeopleDetector(const HogOptions& options);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_HOG_PEOPLE_DETECTOR_H_

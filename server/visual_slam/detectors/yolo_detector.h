#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_YOLO_DETECTOR_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_YOLO_DETECTOR_H_

// YOLO through OpenCV's dnn module on the CPU: the paper's deep detector (METHODS.md section 3
// uses YOLOv3; any darknet YOLOv3/v4-style network loads, e.g. YOLO-Fastest). The model comes as
// bytes, never as a path: robots upload it with the session config, and the server keeps no
// model files of its own.
//
// Two formats:
//  - darknet: `cfg` (text) + `weights`. Input is the cfg's [net] width x height (or input_size),
//    a plain resize unless the cfg says letter_box=1, as darknet trained it. OpenCV's [yolo]
//    layers decode the anchors; each output row is cx, cy, w, h (fractions of the input),
//    objectness, then per-class scores already multiplied by the objectness.
//  - ONNX: `onnx`, a YOLOv5-style export whose first output is [1, N, 5 + classes]: cx, cy, w, h
//    in input pixels, objectness, then class probabilities (score = objectness * probability),
//    fed a letterboxed square image (YOLOv5's preprocessing).
// Boxes of classes not in movable_classes are dropped, the rest go through per-class NMS and are
// clipped to the image.

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/detectors/coco_classes.h"
#include "server/visual_slam/detectors/object_detector.h"

namespace waymark::visual_slam {

struct YoloOptions {
  // The model, as bytes, not paths: robots upload the model with the session config. Exactly one
  // of (cfg and weights) or onnx.
  std::string cfg;
  std::string weights;
  std::string onnx;
  // Label of each class index of the network's output (the model's names file).
  std::vector<std::string> class_names = CocoClassNames();
  // The classes that can move (eq 7's "movable classes"); boxes of other classes are dropped.
  std::vector<std::string> movable_classes = {"person", "car",     "bus",
                                              "truck",  "bicycle", "motorbike"};
  // Minimum class score (objectness x class probability). 0.25 is darknet's own default
  // detection threshold (`darknet detect -thresh .25`): the filter would rather lose a few static
  // features to a doubtful box than track on a person it missed.
  float confidence = 0.25f;
  // Boxes of one class overlapping more than this IoU are merged (darknet's demo value).
  float nms = 0.45f;
  // Square network input side in pixels, a multiple of 32 in [32, 1024]. 0 = the cfg's width x
  // height, or 640 for ONNX (YOLOv5's export size). The cost grows with the area: YOLO-Fastest
  // 1.1 XL on 640x480 frames takes about 24 ms of CPU per frame at its cfg's 320, 19 ms at 256
  // and 37 ms at 416 (waymark-vo-detector-bench, one thread). 320 stays the default: 256 saves
  // 5 ms but finds a car in 39 instead of 46 of the 51 KITTI 06 frames.
  int input_size = 0;
};

// INVALID_ARGUMENT, naming the field, for no model or both formats, cfg/weights/onnx bytes OpenCV
// cannot load (or whose output does not have 5 + class_names.size() columns), an input size out
// of range, a movable class that is not in class_names.
absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeYoloDetector(const YoloOptions& options);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_YOLO_DETECTOR_H_

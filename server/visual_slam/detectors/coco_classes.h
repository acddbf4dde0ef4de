#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_COCO_CLASSES_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_COCO_CLASSES_H_

// The 80 COCO class labels in darknet's coco.names order: class index i of a COCO-trained YOLO
// (darknet or ONNX export) is CocoClassNames()[i]. A constant in the code, so a session that
// uploads only cfg + weights needs no names file.

#include <string>
#include <vector>

namespace waymark::visual_slam {

const std::vector<std::string>& CocoClassNames();

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_COCO_CLASSES_H_

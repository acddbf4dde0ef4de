# Object detectors behind ObjectDetector (YOLO through OpenCV dnn, HOG people).
target_sources(waymark_visual_slam PRIVATE
  detectors/coco_classes.cc
  detectors/yolo_detector.cc
  detectors/hog_people_detector.cc
  detectors/detector_input.cc
  detectors/detector_factory.cc
)

# Object detectors behind ObjectDetector (YOLO through OpenCV dnn, HOG people).
target_sources(waymark_visual_slam PRIVATE
  coco_classes.cc
  yolo_detector.cc
  hog_people_detector.cc
  detector_input.cc
  detector_factory.cc
)

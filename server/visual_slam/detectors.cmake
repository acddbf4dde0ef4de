# Object detectors behind ObjectDetector (YOLO through OpenCV dnn, HOG people).
target_sources(waymark_visual_slam PRIVATE)

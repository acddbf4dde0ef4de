# Object detector tests (YOLO through OpenCV dnn, HOG people, the factory). The frames and the
# model come from ../shared (WAYMARK_SHARED_DIR); the tests that need them skip without it.
waymark_test(yolo_detector_test
  SOURCES yolo_detector_test.cc
  LIBS waymark_visual_slam)
waymark_test(hog_people_detector_test
  SOURCES hog_people_detector_test.cc
  LIBS waymark_visual_slam)
waymark_test(detector_factory_test
  SOURCES detector_factory_test.cc
  LIBS waymark_visual_slam)

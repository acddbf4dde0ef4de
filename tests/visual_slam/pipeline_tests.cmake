# The pipeline end to end (synthetic and, when ../shared is present, real windows).
waymark_test(visual_odometry_test
  SOURCES visual_odometry_test.cc sequence_fixture.cc coarse_matching_test.cc
  LIBS waymark_visual_slam waymark_cli)

# ORB, matching, keyframes and the per-session pipeline.
target_sources(waymark_visual_slam PRIVATE
  types.cc
  options.cc
  camera_check.cc
  frame_features.cc
  frame_validation.cc
  coarse_matching.cc
  frame_tracking.cc
  visual_odometry.cc
)

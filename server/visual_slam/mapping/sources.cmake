# Beyond the paper: the local map of keyframes and points, and its bundle adjustment (Ceres).
target_sources(waymark_visual_slam PRIVATE
  mapping/bundle_adjustment.cc
  mapping/local_map.cc
)

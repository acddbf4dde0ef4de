# ORB, matching, keyframes and the per-session pipeline.
target_sources(waymark_visual_slam PRIVATE
  types.cc
  options.cc
)

# Sampler, solvers and tests on correspondences (eq 7, 10-15, 17).
target_sources(waymark_visual_slam PRIVATE)

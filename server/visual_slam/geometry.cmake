# Sampler, solvers and tests on correspondences (eq 7, 10-15, 17).
target_sources(waymark_visual_slam PRIVATE
  box_split.cc
  essential_solver.cc
  pnp_solver.cc
  sequential_sampler.cc
  static_test.cc
  two_view.cc
)

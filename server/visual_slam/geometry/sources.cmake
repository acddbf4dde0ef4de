# Sampler, solvers and tests on correspondences (eq 7, 10-15, 17).
target_sources(waymark_visual_slam PRIVATE
  geometry/box_split.cc
  geometry/essential_solver.cc
  geometry/pnp_solver.cc
  geometry/sequential_sampler.cc
  geometry/static_test.cc
  geometry/two_view.cc
)

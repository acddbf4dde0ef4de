# Geometry of the visual odometry (server/visual_slam: box split, sampler, solvers, static test).
waymark_test(box_split_test SOURCES box_split_test.cc LIBS waymark_visual_slam)
waymark_test(sequential_sampler_test SOURCES sequential_sampler_test.cc LIBS waymark_visual_slam)
waymark_test(essential_solver_test SOURCES essential_solver_test.cc LIBS waymark_visual_slam)
waymark_test(pnp_solver_test SOURCES pnp_solver_test.cc LIBS waymark_visual_slam)
waymark_test(static_test_test SOURCES static_test_test.cc LIBS waymark_visual_slam)
waymark_test(two_view_test SOURCES two_view_test.cc LIBS waymark_visual_slam)

#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_PNP_SOLVER_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_PNP_SOLVER_H_

// The RGB-D motion model: the reference frame's depth gives each pair a 3-D point, so the motion
// is a perspective-n-point problem. Minimal samples of 3 (P3P, up to 4 motions each), then a
// robust Gauss-Newton (Levenberg-Marquardt) refinement on the reprojection error of the inliers.
// Translations are metric.

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/geometry/correspondence.h"
#include "server/visual_slam/geometry/sequential_sampler.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

class PnpSolver : public MotionSolver {
 public:
  // Keeps a reference to `correspondences`: it must outlive the solver.
  PnpSolver(const std::vector<Correspondence>& correspondences, double focal_px);

  int SampleSize() const override { return 3; }
  // Pairs with a finite reference_point in front of the reference camera.
  bool Samplable(int i) const override;
  // cv::solveP3P's solutions that are finite and put the sample in front of the current camera.
  std::vector<Motion> Solve(const std::vector<int>& sample) const override;
  // |project(R X + t) - current| * focal_px; +inf without reference_point or behind the camera.
  double ErrorPx(const Motion& motion, int i) const override;
  // RefinePnp on the inliers, from `motion`.
  std::optional<Motion> Refine(const Motion& motion,
                               const std::vector<int>& inliers) const override;

 private:
  const std::vector<Correspondence>& correspondences_;
  double focal_px_;
};

// Levenberg-Marquardt on the reprojection error of the inliers with a Huber weight at 1 px,
// starting at `initial`. INVALID_ARGUMENT for fewer than 4 inliers with a reference_point (in
// front of `initial`'s camera), an index out of range or a focal length that is not positive;
// INTERNAL if the iteration leaves the finite numbers.
absl::StatusOr<Motion> RefinePnp(const std::vector<Correspondence>& c,
                                 const std::vector<int>& inliers, const Motion& initial,
                                 double focal_px);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_PNP_SOLVER_H_

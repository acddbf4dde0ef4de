#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_ESSENTIAL_SOLVER_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_ESSENTIAL_SOLVER_H_

// The monocular motion model (eq 13-15): the essential matrix from the epipolar constraint of
// normalized pairs (8-point algorithm with Hartley normalization, then projection onto the
// essential manifold: two equal singular values and a zero one), and its decomposition E = t^ R
// into the one of four (R, t) that puts most pairs in front of both cameras (cheirality vote).
// Translations are directions: |t| = 1. Convention: x_c^T E x_r = 0 (see two_view.h).

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/geometry/correspondence.h"
#include "server/visual_slam/geometry/sequential_sampler.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

class EssentialSolver : public MotionSolver {
 public:
  // Keeps a reference to `correspondences`: it must outlive the solver.
  EssentialSolver(const std::vector<Correspondence>& correspondences, double focal_px);

  // 5: the minimal solver (FivePoint). A pure sample of 5 is far likelier than one of 8 among
  // outliers (0.6^5 = 8 % vs 0.6^8 = 2 % at 40 % outliers), which matters with the 4 x 32
  // samples of the default SamplerOptions.
  int SampleSize() const override { return 5; }
  // 5 pairs: FivePoint (up to 10 motions). 8 or more: the 8-point algorithm, at most one motion;
  // none for a degenerate sample (points on a line, no translation, ...).
  std::vector<Motion> Solve(const std::vector<int>& sample) const override;
  // Sampson distance to the epipolar constraint of `motion`, times focal_px.
  double ErrorPx(const Motion& motion, int i) const override;
  void ErrorsPx(const Motion& motion, const std::vector<int>& indices,
                std::vector<double>* errors) const override;
  bool UnitTranslation() const override { return true; }
  // EssentialFromInliers on the inliers.
  std::optional<Motion> Refine(const Motion& motion,
                               const std::vector<int>& inliers) const override;

 private:
  const std::vector<Correspondence>& correspondences_;
  double focal_px_;
};

// The motions of the (up to 10) essential matrices through exactly 5 pairs (Nister's five-point
// solver, through cv::findEssentialMat, which runs it once and stacks its solutions when given
// exactly 5 pairs), each decomposed with the cheirality vote on the 5 pairs. Empty when the
// pairs are not 5, out of range or degenerate.
std::vector<Motion> FivePoint(const std::vector<Correspondence>& c, const std::vector<int>& sample);

// A local Levenberg-Marquardt polish of `start` on the Sampson errors of `indices` (Huber at about
// 1 px): it stays in the basin of `start`, unlike a solution from scratch, which matters where far
// points leave two motions almost equally consistent. `start` itself for fewer than 5 pairs or an
// index out of range.
Motion PolishOnSampson(const Motion& start, const std::vector<Correspondence>& c,
                       const std::vector<int>& indices);

// E from >= 8 pairs (least squares over all of them), projected onto the essential manifold
// (Frobenius norm sqrt(2)); nullopt when the pairs do not determine E (the constraint matrix has
// more than a one-dimensional null space: fewer than 8 distinct pairs, degenerate structure or
// no translation) or an index is out of range.
std::optional<Eigen::Matrix3d> EssentialFromPairs(const std::vector<Correspondence>& c,
                                                  const std::vector<int>& indices);

// The (R, t), |t| = 1, of E = t^ R that puts most of `indices` in front of both cameras, with that
// count; nullopt when none is in front.
struct Decomposition {
  Motion motion;
  int in_front = 0;
};
std::optional<Decomposition> DecomposeEssential(const Eigen::Matrix3d& E,
                                                const std::vector<Correspondence>& c,
                                                const std::vector<int>& indices);

// eq 14-15 over all inliers (least squares, >= 8), decomposition with cheirality over all inliers,
// then a Levenberg-Marquardt polish of (R, t) on the inliers' Sampson errors (Huber at ~1 px); the
// linear solution alone is kept if the polish would change the cheirality decision.
// |t| = 1. INVALID_ARGUMENT for fewer than 8 inliers or an index out of range;
// FAILED_PRECONDITION when the inliers do not determine a motion (degenerate E, or fewer than
// half of them in front of both cameras under every decomposition).
absl::StatusOr<Motion> EssentialFromInliers(const std::vector<Correspondence>& c,
                                            const std::vector<int>& inliers);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_ESSENTIAL_SOLVER_H_

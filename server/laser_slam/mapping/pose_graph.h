#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_GRAPH_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_GRAPH_H_

// A 2-D pose graph solved with Ceres (sparse normal Cholesky): node poses (x, y, theta) tied by
// relative-pose constraints with a covariance, loop constraints under a Huber loss. The first
// node is held fixed (the gauge). Plain value types so that the back end can copy a graph out of
// its lock and solve it on its own thread.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct GraphConstraint {
  enum class Kind : std::uint8_t { kChain = 0, kLoop = 1 };
  Kind kind = Kind::kChain;
  int from = 0;                 // node indices
  int to = 0;
  Pose2 relative;               // pose of `to` in the frame of `from`
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  // 1 sigma of (x, y, theta) of `relative`
  bool enabled = true;          // loop constraints found inconsistent are switched off
  double score = 0.0;           // match score of a loop constraint
};

struct GraphSolveOptions {
  double huber_scale = 1.0;
  int max_iterations = 50;
};

struct GraphSolveReport {
  bool converged = false;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
};

// Optimises `poses` in place. Constraints with out-of-range indices are ignored.
GraphSolveReport SolvePoseGraph(std::vector<Pose2>& poses,
                                const std::vector<GraphConstraint>& constraints,
                                const GraphSolveOptions& options);

// SolvePoseGraph, then: a loop constraint whose whitened residual at the optimum exceeds
// `outlier_residual` contradicts the others; the worst one is switched off (enabled = false) and
// the graph solved again, for up to `max_rounds` rounds (one at a time, since one wrong closure
// can drag the residuals of its right neighbours up with it). Returns how many were switched off.
int SolveRejectingOutliers(std::vector<Pose2>& poses, std::vector<GraphConstraint>& constraints,
                           const GraphSolveOptions& options, double outlier_residual,
                           int max_rounds = 5);

// Whitened residual norm of one constraint at `poses`.
double ConstraintResidual(const std::vector<Pose2>& poses, const GraphConstraint& constraint);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_GRAPH_H_

#include "server/laser_slam/mapping/pose_graph.h"

#include <cmath>
#include <memory>

#include <ceres/ceres.h>

#include "server/laser_slam/geometry.h"

static_assert(sizeof(waymark::laser_slam::Pose2) == 3 * sizeof(double));

namespace waymark::laser_slam {
namespace {

template <typename T>
T WrapAngle(const T& a) {
  const T two_pi(2.0 * M_PI);
  return a - two_pi * ceres::floor((a + T(M_PI)) / two_pi);
}

// Residual of a relative-pose constraint: the predicted pose of `to` in `from`'s frame minus the
// measured one, whitened by the constraint's sigmas.
struct RelativePoseError {
  RelativePoseError(const Pose2& measured, const Eigen::Vector3d& sigma)
      : measured(measured), inverse_sigma(sigma.cwiseInverse()) {}

  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const T c = ceres::cos(a[2]), s = ceres::sin(a[2]);
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    residual[0] = (c * dx + s * dy - T(measured.x)) * T(inverse_sigma(0));
    residual[1] = (-s * dx + c * dy - T(measured.y)) * T(inverse_sigma(1));
    residual[2] = WrapAngle(b[2] - a[2] - T(measured.theta)) * T(inverse_sigma(2));
    return true;
  }

  Pose2 measured;
  Eigen::Vector3d inverse_sigma;
};

}  // namespace

double ConstraintResidual(const std::vector<Pose2>& poses, const GraphConstraint& c) {
  const Pose2 predicted = Relative(poses[c.from], poses[c.to]);
  const Eigen::Vector3d error(predicted.x - c.relative.x, predicted.y - c.relative.y,
                              NormalizeAngle(predicted.theta - c.relative.theta));
  return error.cwiseQuotient(c.sigma).norm();
}

GraphSolveReport SolvePoseGraph(std::vector<Pose2>& poses,
                                const std::vector<GraphConstraint>& constraints,
                                const GraphSolveOptions& options) {
  GraphSolveReport report;
  if (poses.size() < 2) return report;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss huber(options.huber_scale);
  const int n = static_cast<int>(poses.size());
  for (const GraphConstraint& c : constraints) {
    if (!c.enabled || c.from < 0 || c.to < 0 || c.from >= n || c.to >= n || c.from == c.to) {
      continue;
    }
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseError, 3, 3, 3>(
        new RelativePoseError(c.relative, c.sigma));
    // Pose2 is three contiguous doubles (x, y, theta): one parameter block per node.
    problem.AddResidualBlock(cost, c.kind == GraphConstraint::Kind::kLoop ? &huber : nullptr,
                             &poses[c.from].x, &poses[c.to].x);
  }
  if (problem.HasParameterBlock(&poses.front().x)) problem.SetParameterBlockConstant(&poses.front().x);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  for (Pose2& p : poses) p.theta = NormalizeAngle(p.theta);
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  report.iterations = static_cast<int>(summary.iterations.size());
  report.initial_cost = summary.initial_cost;
  report.final_cost = summary.final_cost;
  return report;
}

int SolveRejectingOutliers(std::vector<Pose2>& poses, std::vector<GraphConstraint>& constraints,
                           const GraphSolveOptions& options, double outlier_residual,
                           int max_rounds) {
  SolvePoseGraph(poses, constraints, options);
  int switched_off = 0;
  for (int round = 0; round < max_rounds; ++round) {
    int worst = -1;
    double worst_residual = outlier_residual;
    for (int i = 0; i < static_cast<int>(constraints.size()); ++i) {
      const GraphConstraint& c = constraints[i];
      if (c.kind != GraphConstraint::Kind::kLoop || !c.enabled) continue;
      const double r = ConstraintResidual(poses, c);
      if (r > worst_residual) {
        worst_residual = r;
        worst = i;
      }
    }
    if (worst < 0) break;
    constraints[worst].enabled = false;
    ++switched_off;
    SolvePoseGraph(poses, constraints, options);
  }
  return switched_off;
}

}  // namespace waymark::laser_slam

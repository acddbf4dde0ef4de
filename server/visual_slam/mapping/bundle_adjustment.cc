#include "server/visual_slam/mapping/bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include "absl/strings/str_cat.h"

namespace waymark::visual_slam {
namespace {

// A camera as Ceres moves it: world-to-camera angle-axis rotation, then translation.
using CameraBlock = std::array<double, 6>;

CameraBlock ToBlock(const Pose& pose) {
  const Eigen::Matrix3d R_cw = pose.R.transpose();
  const Eigen::Vector3d t_cw = -R_cw * pose.t;
  const Eigen::AngleAxisd angle_axis(R_cw);
  const Eigen::Vector3d w = angle_axis.angle() * angle_axis.axis();
  return {w.x(), w.y(), w.z(), t_cw.x(), t_cw.y(), t_cw.z()};
}

Pose FromBlock(const CameraBlock& block) {
  const Eigen::Vector3d w(block[0], block[1], block[2]);
  const double angle = w.norm();
  const Eigen::Matrix3d R_cw = angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                         : Eigen::Matrix3d::Identity();
  Pose pose;
  pose.R = R_cw.transpose();
  pose.t = -pose.R * Eigen::Vector3d(block[3], block[4], block[5]);
  return pose;
}

// Below this depth (m, or scale-free units) a point is not in front of the camera.
constexpr double kMinDepth = 1e-6;

template <typename T>
bool InCamera(const T* camera, const T* point, T* in_camera) {
  ceres::AngleAxisRotatePoint(camera, point, in_camera);
  for (int i = 0; i < 3; ++i) in_camera[i] += camera[3 + i];
  return in_camera[2] > T(kMinDepth);
}

struct ReprojectionResidual {
  ReprojectionResidual(const Eigen::Vector2d& normalized, double focal_px)
      : u(normalized.x()), v(normalized.y()), focal(focal_px) {}
  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    T p[3];
    if (!InCamera(camera, point, p)) return false;  // Ceres rejects the step
    residual[0] = T(focal) * (p[0] / p[2] - T(u));
    residual[1] = T(focal) * (p[1] / p[2] - T(v));
    return true;
  }
  double u, v, focal;
};

// ORB-SLAM2's RGB-D residual: the disparity a stereo camera with baseline-times-focal bf would
// measure, predicted against measured. Near points weigh more, as their depth is better known.
struct DisparityResidual {
  DisparityResidual(double depth_m, double bf) : inverse_depth(1.0 / depth_m), bf(bf) {}
  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    T p[3];
    if (!InCamera(camera, point, p)) return false;
    residual[0] = T(bf) * (T(1.0) / p[2] - T(inverse_depth));
    return true;
  }
  double inverse_depth, bf;
};

}  // namespace

double ReprojectionErrorPx(const Pose& camera, const Eigen::Vector3d& point,
                           const Eigen::Vector2d& normalized, double focal_px) {
  const Eigen::Vector3d p = camera.R.transpose() * (point - camera.t);
  if (!(p.z() > kMinDepth)) return std::numeric_limits<double>::infinity();
  return focal_px * (p.head<2>() / p.z() - normalized).norm();
}

absl::StatusOr<BundleResult> BundleAdjust(const BundleProblem& problem,
                                          const BundleOptions& options) {
  const int cameras = static_cast<int>(problem.cameras.size());
  const int points = static_cast<int>(problem.points.size());
  bool any_fixed = false;
  for (const BundleCamera& camera : problem.cameras) {
    if (!IsFinite(camera.pose)) return absl::InvalidArgumentError("a camera pose is not finite");
    any_fixed |= camera.fixed;
  }
  if (!any_fixed) {
    return absl::InvalidArgumentError("no fixed camera: the gauge would be free");
  }
  for (const Eigen::Vector3d& point : problem.points) {
    if (!point.allFinite()) return absl::InvalidArgumentError("a point is not finite");
  }
  for (const BundleObservation& o : problem.observations) {
    if (o.camera < 0 || o.camera >= cameras || o.point < 0 || o.point >= points) {
      return absl::InvalidArgumentError(
          absl::StrCat("observation of point ", o.point, " in camera ", o.camera, " out of range"));
    }
    if (!o.normalized.allFinite() || (o.depth && !(std::isfinite(*o.depth) && *o.depth > 0))) {
      return absl::InvalidArgumentError("an observation is not finite");
    }
  }

  std::vector<CameraBlock> camera_blocks(cameras);
  for (int i = 0; i < cameras; ++i) camera_blocks[i] = ToBlock(problem.cameras[i].pose);
  std::vector<Eigen::Vector3d> point_blocks = problem.points;
  const auto current_pose = [&](int i) {
    return problem.cameras[i].fixed ? problem.cameras[i].pose : FromBlock(camera_blocks[i]);
  };
  const auto error_px = [&](const BundleObservation& o) {
    return ReprojectionErrorPx(current_pose(o.camera), point_blocks[o.point], o.normalized,
                               options.focal_px);
  };

  BundleResult result;
  // A point behind the camera cannot start the optimisation (the residual is undefined there).
  result.outlier.assign(problem.observations.size(), false);
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    result.outlier[k] = !std::isfinite(error_px(problem.observations[k]));
  }
  // One Huber loss per residual kind, shared by every block: a problem must not delete them once
  // per block, so they are owned here (and outlive the problems, declared after them).
  const auto reprojection_loss = std::make_unique<ceres::HuberLoss>(options.huber_px);
  const auto disparity_loss = std::make_unique<ceres::HuberLoss>(options.huber_px);
  for (int round = 0; round < std::max(1, options.rounds); ++round) {
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem solver_problem(problem_options);
    std::vector<bool> camera_used(cameras, false);
    for (size_t k = 0; k < problem.observations.size(); ++k) {
      if (result.outlier[k]) continue;
      const BundleObservation& o = problem.observations[k];
      double* camera = camera_blocks[o.camera].data();
      double* point = point_blocks[o.point].data();
      solver_problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 6, 3>(
              new ReprojectionResidual(o.normalized, options.focal_px)),
          reprojection_loss.get(), camera, point);
      if (o.depth && options.stereo_bf > 0) {
        solver_problem.AddResidualBlock(new ceres::AutoDiffCostFunction<DisparityResidual, 1, 6, 3>(
                                            new DisparityResidual(*o.depth, options.stereo_bf)),
                                        disparity_loss.get(), camera, point);
      }
      camera_used[o.camera] = true;
    }
    for (int i = 0; i < cameras; ++i) {
      if (camera_used[i] && problem.cameras[i].fixed) {
        solver_problem.SetParameterBlockConstant(camera_blocks[i].data());
      }
    }
    if (solver_problem.NumResidualBlocks() > 0) {
      ceres::Solver::Options solver_options;
      solver_options.linear_solver_type = ceres::DENSE_SCHUR;  // a window of a few cameras
      solver_options.max_num_iterations = options.max_iterations;
      solver_options.num_threads = 1;  // beside tracking on a small robot computer
      solver_options.logging_type = ceres::SILENT;
      ceres::Solver::Summary summary;
      ceres::Solve(solver_options, &solver_problem, &summary);
      if (round == 0) result.initial_cost = summary.initial_cost;
      result.final_cost = summary.final_cost;
      result.iterations += static_cast<int>(summary.iterations.size());
    }
    // Observations that stay far off leave the next round (and are reported).
    for (size_t k = 0; k < problem.observations.size(); ++k) {
      if (!result.outlier[k]) {
        result.outlier[k] = !(error_px(problem.observations[k]) <= options.outlier_px);
      }
    }
  }

  result.cameras.reserve(cameras);
  for (int i = 0; i < cameras; ++i) result.cameras.push_back(current_pose(i));
  result.points = std::move(point_blocks);
  return result;
}

}  // namespace waymark::visual_slam

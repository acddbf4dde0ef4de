#ifndef WAYMARK_SERVER_LASER_SLAM_SP_JACOBIANS_H_
#define WAYMARK_SERVER_LASER_SLAM_SP_JACOBIANS_H_

// The SP-model functions the EKF linearises, with their Jacobians at zero perturbation. They are
// written once as templates over the scalar and differentiated exactly with Eigen's
// AutoDiffScalar, which removes the hand-derived-Jacobian sign errors that plague EKF code; the
// tests compare them with numeric differentiation.

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// z = (-)(S (+) (0, a_y, a_theta)) (+) (P (+) b (+) Q (+) (0, c_y, c_theta)):
// the location of a perturbed line frame (P, Q, b, c) relative to another perturbed line frame
// (S, a). Two lines coincide iff z_y = 0 and z_theta = 0; z_x is where the second frame's origin
// sits along the first line.
// Observation of a scan segment: S = map segment, P = robot, b = robot perturbation d_R,
// Q = the observed segment's frame in the robot frame, c = its line perturbation.
// Two map segments (merging): P = the second segment's frame, Q = identity, b unused.
struct RelativeLine {
  Eigen::Vector3d z;                      // at zero perturbation; z_theta wrapped to (-pi, pi]
  Eigen::Matrix<double, 3, 2> d_a;        // dz/d(a_y, a_theta)
  Eigen::Matrix<double, 3, 3> d_b;        // dz/db
  Eigen::Matrix<double, 3, 2> d_c;        // dz/d(c_y, c_theta)
};
RelativeLine RelateLines(const Pose2& s, const Pose2& p, const Pose2& q);

// Odometry prediction. With the robot at R (+) d and a measured increment u whose error e acts at
// the end of the motion, the new perturbation is d' = (-)u (+) d (+) u (+) e. Returns dd'/dd.
// (dd'/de is the identity.)
Eigen::Matrix3d PredictionJacobian(const Pose2& u);

// Centering a robot: new estimate R (+) delta, new perturbation d' = (-)delta (+) d.
// Returns dd'/dd at d = delta.
Eigen::Matrix3d RobotCenteringJacobian(const Eigen::Vector3d& delta);

// Centering a line: new estimate S (+) (0, delta_y, delta_theta); the new line perturbation is the
// (y, theta) of (-)(0, delta) (+) (0, p) re-expressed as a line (intercept at x = 0).
// Returns d(p_y', p_theta')/d(p_y, p_theta) at p = delta.
Eigen::Matrix2d LineCenteringJacobian(const Eigen::Vector2d& delta);

// Moving a segment frame by `shift` along its own line keeps the line and changes the
// perturbation's intercept: p_y' = p_y + shift * tan(p_theta). Jacobian at p_theta = 0.
Eigen::Matrix2d LineShiftJacobian(double shift);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_SP_JACOBIANS_H_

#ifndef WAYMARK_SERVER_LASER_SLAM_LINE_FIT_H_
#define WAYMARK_SERVER_LASER_SLAM_LINE_FIT_H_

// Weighted least-squares fit of a polar line to consecutive laser readings, with the first-order
// covariance of (rho, phi) (used by line_extraction.cc).
//
// The line is {x : x . n = rho}, n = (cos phi, sin phi), rho >= 0; t = (-sin phi, cos phi) is its
// direction and x . t the abscissa ("tau") of a point along it, measured from the foot of the
// perpendicular from the sensor.

#include <vector>

#include <Eigen/Core>

namespace waymark::laser_slam {

// One beam of a scan in the laser frame. Only `valid` beams carry a point.
struct ScanPoint {
  double x = 0.0, y = 0.0;  // the point
  double r = 0.0;           // its range
  double c = 1.0, s = 0.0;  // cos and sin of the beam's bearing
  bool valid = false;
};

struct PolarLine {
  double rho = 0.0;
  double phi = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // of (rho, phi)
  bool ok = false;  // false when fewer than two distinct points supported the fit

  double nx() const;
  double ny() const;
  // Signed distance of (x, y) from the line, positive on the far side (away from the sensor).
  double Distance(double x, double y) const;
  // Abscissa of (x, y) along the line direction t.
  double Tau(double x, double y) const;
};

// Weighted least-squares line through points[first..last] (inclusive, all valid). Each reading's
// orthogonal residual d_i = r_i cos(a_i - phi) - rho has variance
//   sigma_r^2 cos^2(a_i - phi) + r_i^2 sigma_b^2 sin^2(a_i - phi)
// (range noise along the beam, bearing noise across it); the fit minimises sum d_i^2 / var_i with
// the weights re-evaluated at the current phi (an unweighted fit starts it, two reweighted passes
// follow; the weights change little with phi, so this converges at once). The covariance is the
// inverse of the Fisher information sum_i w_i J_i^T J_i, J_i = d d_i / d(rho, phi) = (-1, tau_i),
// which is the first-order propagation of the per-reading noise through the weighted estimator when
// the weights are the true inverse residual variances (the sandwich form collapses to it).
PolarLine FitLine(const std::vector<ScanPoint>& points, int first, int last, double range_sigma,
                  double bearing_sigma);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_LINE_FIT_H_

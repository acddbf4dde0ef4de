#ifndef WAYMARK_SERVER_LASER_SLAM_TYPES_H_
#define WAYMARK_SERVER_LASER_SLAM_TYPES_H_

// Value types shared by the laser SLAM engine: poses, scans, observed and mapped segments.
// Units are SI: metres, radians, seconds. Angles are normalised to (-pi, pi].

#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace waymark::laser_slam {

// A 2-D rigid transform / location (x, y, theta): the frame's origin and the direction of its x axis.
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

// How the beams of a scan are laid out, as the scan message says (never assumed).
struct ScanGeometry {
  double angle_min = 0.0;        // bearing of the first beam in the laser frame (rad)
  double angle_increment = 0.0;  // bearing step between consecutive beams (rad, may be negative)
  int beam_count = 0;            // number of ranges a scan carries
  // Readings at or above this value mean "no return" (the sensor's max-range marker). 0 = none.
  double no_return_range = 0.0;
};

// Whether `range` is a real return under `geometry`: NaN, infinite, negative, zero and readings
// at or above the no-return marker are not.
inline bool IsReturn(double range, const ScanGeometry& geometry) {
  return std::isfinite(range) && range > 0.0 &&
         !(geometry.no_return_range > 0.0 && range >= geometry.no_return_range);
}

struct LaserScan {
  double stamp = 0.0;
  ScanGeometry geometry;
  // One range per beam, metres. NaN, infinite, negative or zero values are no-returns.
  std::vector<float> ranges;
};

// Cumulative wheel-odometry pose of the robot at `stamp`, in the odometry frame.
struct OdometryReading {
  double stamp = 0.0;
  Pose2 pose;
};

enum class EndpointType : std::uint8_t {
  kVirtual = 0,  // cut by range, field of view or occlusion: the wall goes on
  kReal = 1,     // a corner or a wall end that the laser actually saw
};

// A segment extracted from one scan, in the laser frame (SP model, METHODS.md section 2).
// Its reference frame sits on the fitted line with the x axis along the line; the endpoints are
// abscissae along that x axis (left < right).
struct ObservedSegment {
  Pose2 frame;                       // location of the segment frame in the laser frame
  double left = 0.0;                 // abscissa of the left endpoint (usually -length/2)
  double right = 0.0;                // abscissa of the right endpoint (usually +length/2)
  EndpointType left_type = EndpointType::kVirtual;
  EndpointType right_type = EndpointType::kVirtual;
  // Covariance of the line perturbation (p_y, p_theta) in the segment frame.
  Eigen::Matrix2d line_covariance = Eigen::Matrix2d::Identity();
  // Variance of each endpoint's position along the line (m^2).
  double left_variance = 0.0;
  double right_variance = 0.0;
  // Polar form of the line in the laser frame (rho >= 0, phi) and its covariance, for reference.
  double rho = 0.0;
  double phi = 0.0;
  Eigen::Matrix2d polar_covariance = Eigen::Matrix2d::Identity();
  int first_beam = 0;   // index of the first and last beam that supported the fit
  int last_beam = 0;
  int point_count = 0;
};

struct PoseEstimate {
  double stamp = 0.0;
  Pose2 pose;                                        // robot pose in the map frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of (x, y, theta)
};

// A segment of the map in the map frame, as the SP model holds it.
struct MapSegment {
  std::uint64_t id = 0;
  Pose2 frame;             // on the line, x axis along it
  double left = 0.0;       // endpoint abscissae along the frame's x axis, left < right
  double right = 0.0;
  EndpointType left_type = EndpointType::kVirtual;
  EndpointType right_type = EndpointType::kVirtual;
  Eigen::Matrix2d line_covariance = Eigen::Matrix2d::Zero();  // of (p_y, p_theta)
  double left_variance = 0.0;   // of the endpoint along the line; 0 for a virtual endpoint
  double right_variance = 0.0;
  int observations = 0;         // scans that matched it
  std::uint64_t last_seen_scan = 0;  // 1-based index of the last scan that matched it
  // In the filter's active window; false = frozen (marginalised out, see EkfOptions).
  bool active = true;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_TYPES_H_

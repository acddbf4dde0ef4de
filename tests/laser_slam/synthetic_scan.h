#ifndef WAYMARK_TESTS_LASER_SLAM_SYNTHETIC_SCAN_H_
#define WAYMARK_TESTS_LASER_SLAM_SYNTHETIC_SCAN_H_

// A small 2-D ray caster for laser SLAM tests: walls are line segments in the world frame, the
// laser sits at a pose, each beam returns the nearest wall along its ray with optional Gaussian
// range and bearing noise (bearing noise: the beam is fired slightly off its nominal bearing but
// reported at the nominal one).

#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam::testing {

struct Wall {
  Eigen::Vector2d a;
  Eigen::Vector2d b;
};

struct RayCastOptions {
  double range_sigma = 0.0;    // Gaussian range noise, 1 sigma (m)
  double bearing_sigma = 0.0;  // Gaussian bearing noise, 1 sigma (rad)
  // Rays that hit nothing within this distance return geometry.no_return_range when that is > 0,
  // +infinity otherwise.
  double sensor_range = 8.0;
};

// The SICK LMS200 layout of METHODS.md: 361 beams over [-90, 90] degrees, 0.5 degree apart.
ScanGeometry Lms200Geometry(double no_return_range = 0.0);

// The LMS200 at 1 degree resolution: 181 beams over [-90, 90] degrees, no-return range 8.183 m.
ScanGeometry Lms200OneDegreeGeometry();

// A map segment with the given id from (x1, y1) (its left end) to (x2, y2) (its right end): frame
// at the midpoint with the x axis along the segment; covariances and observations left at zero.
MapSegment SegmentBetween(std::uint64_t id, double x1, double y1, double x2, double y2,
                          EndpointType left_type, EndpointType right_type);

// Every wall as a mapped segment (ids 1, 2, ...; real endpoints): the segment map a session would
// have once it saw them all.
std::vector<MapSegment> SegmentsOf(const std::vector<Wall>& walls);

// Distance along the ray from `origin` in direction `angle` to the nearest wall, or a negative
// value when no wall is hit.
double CastRay(const std::vector<Wall>& walls, const Eigen::Vector2d& origin, double angle);

// One scan of `walls` from a laser at `laser_pose` (world frame). `rng` may be null when both noise
// sigmas are zero.
LaserScan CastScan(const std::vector<Wall>& walls, const Pose2& laser_pose,
                   const ScanGeometry& geometry, const RayCastOptions& options, std::mt19937* rng);

// The returns of one noise-free LMS200 scan (0.5 degree, 12 m) of `walls` from `pose`, as the back
// end keeps them: points in the robot frame (the laser at its origin).
std::vector<Eigen::Vector2f> ScanPoints(const std::vector<Wall>& walls, const Pose2& pose);

// Axis-aligned rectangle [x0, x1] x [y0, y1] as four walls.
std::vector<Wall> Box(double x0, double y0, double x1, double y1);

// A 20 x 12 m hall with irregular pillars and walls: no two places in it look alike (the shared
// map's tests: trajectory_tie_test.cc, trajectory_follow_test.cc, map_tie_worker_test.cc).
std::vector<Wall> PillarOffice();

// True poses every `step` metres along the polyline, heading along each leg.
std::vector<Pose2> PolylinePath(const std::vector<Eigen::Vector2d>& corners, double step);

// One lap around the pillars of PillarOffice(), back to its start: 30 m, a pose every 0.25 m
// (the lifelong tests and waymark-laser-revisit drive it again and again).
std::vector<Pose2> PillarOfficeLap();

// `own` moved by the true step from `from` to `to` as a drifting odometry counts it: 1 % long and
// turning 0.002 rad to the left per step.
Pose2 DriftingStep(const Pose2& own, const Pose2& from, const Pose2& to);

}  // namespace waymark::laser_slam::testing

#endif  // WAYMARK_TESTS_LASER_SLAM_SYNTHETIC_SCAN_H_

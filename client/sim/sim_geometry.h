#ifndef WAYMARK_CLIENT_SIM_SIM_GEOMETRY_H_
#define WAYMARK_CLIENT_SIM_SIM_GEOMETRY_H_

// Plane geometry for the robot simulator: distances from a point to walls and ray casting.
// Walls are line segments (sim_world.h); a degenerate (zero-length) wall is a point.

#include <vector>

#include "client/devices/robot_devices.h"
#include "client/sim/sim_world.h"

namespace waymark::adapters::geometry {

// Euclidean distance from (px, py) to the closest point of the segment.
double PointSegmentDistance(double px, double py, const Wall& wall);

// Distance from (px, py) to the nearest wall; +infinity when there are none.
double Clearance(const std::vector<Wall>& walls, double px, double py);

// Distance t >= 0 along the ray (ox, oy) + t * (dx, dy), (dx, dy) a unit vector, at which it meets
// the segment; +infinity when it misses. A ray parallel to the segment misses it.
double RaySegmentHit(double ox, double oy, double dx, double dy, const Wall& wall);

// The nearest RaySegmentHit over all walls; +infinity when the ray meets none.
double CastRay(const std::vector<Wall>& walls, double ox, double oy, double dx, double dy);

// Angle wrapped into [-pi, pi].
double WrapAngle(double angle);

// `local` (a pose in the frame of `frame`) in the frame `frame` lives in.
BasePose Compose(const BasePose& frame, const BasePose& local);

// Moves `pose` along a circular arc of length `distance` (signed, along the heading) while its
// heading turns by `turn`; a straight line when `turn` is 0. Exact for constant velocities.
void ApplyArc(BasePose& pose, double distance, double turn);

}  // namespace waymark::adapters::geometry

#endif  // WAYMARK_CLIENT_SIM_SIM_GEOMETRY_H_

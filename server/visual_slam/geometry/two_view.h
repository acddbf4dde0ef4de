#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_TWO_VIEW_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_TWO_VIEW_H_

// Two-view helpers shared by the solvers, the static test and the monocular scale: the skew
// matrix, the essential matrix of a motion, the Sampson and epipolar-line distances and
// triangulation. All in normalized image coordinates; Motion maps reference to current
// coordinates, X_c = R X_r + t.
//
// Convention: with X_c = R X_r + t the epipolar constraint is x_c^T E x_r = 0 with E = t^ R
// (eq 15). Eq 14 of the paper writes the reference point on the left; its E is our E transposed.

#include <Eigen/Core>
#include <optional>

#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

// E = t^ R (eq 15).
Eigen::Matrix3d EssentialOf(const Motion& motion);

// First-order (Sampson) distance of a pair to x_c^T E x_r = 0, in normalized units; +inf when
// undefined (E maps the points to zero).
double SampsonDistance(const Eigen::Matrix3d& E, const Eigen::Vector2d& reference,
                       const Eigen::Vector2d& current);

// Distance of `current` to the epipolar line E * reference in the current image (normalized
// units); +inf when the line is undefined.
double EpipolarLineDistance(const Eigen::Matrix3d& E, const Eigen::Vector2d& reference,
                            const Eigen::Vector2d& current);

// Depths (along the z axis) of a pair in the reference and the current camera under `motion`,
// by least squares on d_c x_c = R d_r x_r + t; nullopt when the rays are parallel.
std::optional<Eigen::Vector2d> PairDepths(const Motion& motion, const Eigen::Vector2d& reference,
                                          const Eigen::Vector2d& current);

// Triangulates a pair under `motion` (reference -> current): the midpoint of the two rays' closest
// points, in reference-camera coordinates, or nullopt when it is behind either camera or the rays
// are nearly parallel (angle between them below min_parallax_rad). The scale is motion.t's.
std::optional<Eigen::Vector3d> Triangulate(const Motion& motion, const Eigen::Vector2d& reference,
                                           const Eigen::Vector2d& current,
                                           double min_parallax_rad = 0.002);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_TWO_VIEW_H_

#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_CORRESPONDENCE_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_CORRESPONDENCE_H_

// A coarse match (eq 8) between a reference-frame feature and a current-frame feature, in the
// form the geometry (sampler, solvers, static test) works on: undistorted normalized image
// coordinates, so that the solvers need no camera model; pixel errors are normalized errors
// times the focal length.

#include <Eigen/Core>
#include <optional>

namespace waymark::visual_slam {

struct Correspondence {
  Eigen::Vector2d reference = Eigen::Vector2d::Zero();  // (x/z, y/z) in the reference frame
  Eigen::Vector2d current = Eigen::Vector2d::Zero();    // same, current frame
  // 3-D point in the reference camera (m), when the reference frame had depth there (RGB-D).
  std::optional<Eigen::Vector3d> reference_point;
  int hamming = 0;  // descriptor distance of the pair
};

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_CORRESPONDENCE_H_

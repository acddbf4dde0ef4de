#ifndef WAYMARK_SERVER_VISUAL_SLAM_CAMERA_CHECK_H_
#define WAYMARK_SERVER_VISUAL_SLAM_CAMERA_CHECK_H_

// Whether a session's intrinsics fit its images (issue 35): intrinsics of another camera are
// accepted (they are numbers), and tracking still answers every frame, but its poses mean little.
// `vo run <Bonn folder> --camera kitti` printed an ATE of 0.06 m with a Sim(3) scale of 0.013.

#include <string>
#include <vector>

#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// The plausible range of a focal length as a multiple of the image width: a horizontal field of
// view between about 19 and 136 degrees (fisheye and telephoto lenses fall outside: they warn).
inline constexpr double kMinFocalPerWidth = 0.2;
inline constexpr double kMaxFocalPerWidth = 3.0;
// The principal point of a real camera lies near the image centre; further than this fraction of
// the side from it (a quarter: the central half of the image) it belongs to another image size.
inline constexpr double kMaxPrincipalOffset = 0.25;
// fx / fy beyond this ratio either way (square pixels give 1).
inline constexpr double kMaxAspect = 1.25;

// One sentence per problem, empty when the intrinsics fit: the principal point outside the frame
// or far from its centre, a focal length implausible for the image width, fx and fy far apart.
std::vector<std::string> CameraWarnings(const CameraModel& camera);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_CAMERA_CHECK_H_

#ifndef WAYMARK_SERVER_VISUAL_SLAM_FRAME_VALIDATION_H_
#define WAYMARK_SERVER_VISUAL_SLAM_FRAME_VALIDATION_H_

// Admission checks for a session's camera and frames: everything a robot can get wrong is an
// INVALID_ARGUMENT that names the field and the values, checked before any state changes.

#include <optional>

#include "absl/status/status.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// Positive finite focal lengths, a principal point inside the image, a size in [16, 8192] pixels,
// finite distortion coefficients.
absl::Status ValidateCamera(const CameraModel& camera);

// A frame for a session whose last stamp is `last_stamp` and whose first frame fixed
// `with_depth` (unset before the first frame): finite stamp after the last one, an 8-bit 1- or
// 3-channel image of the camera's size, depth empty or CV_16UC1 of the same size (and present or
// absent like the first frame's), finite boxes.
absl::Status ValidateFrame(const FrameInput& frame, const CameraModel& camera,
                           std::optional<double> last_stamp, std::optional<bool> with_depth);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_FRAME_VALIDATION_H_

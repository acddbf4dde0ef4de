#ifndef WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_INPUT_H_
#define WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_INPUT_H_

// What every ObjectDetector::Detect does around its own work: refuse an image that is not 8-bit
// gray or BGR, convert it to the channel count the detector runs on, and turn whatever OpenCV
// throws (cv::Exception, std::bad_alloc on a huge frame) into INTERNAL, so nothing escapes
// Detect() on client data.

#include <exception>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// e.what() without the trailing newline OpenCV's messages end with.
std::string ExceptionMessage(const std::exception& e);

// Checks `image`, converts it to `channels` (1: gray, 3: BGR) and runs `detect` on the result.
// INVALID_ARGUMENT "<detector>: ..." for an empty image or one of another depth or channel count;
// INTERNAL "<detector>: ..." for an exception from the conversion or from `detect`.
absl::StatusOr<std::vector<Box>> DetectGuarded(
    absl::string_view detector, const cv::Mat& image, int channels,
    const std::function<absl::StatusOr<std::vector<Box>>(const cv::Mat& converted)>& detect);

// `rect` clipped to `frame` (the image) as a Box; nullopt when no part of it is inside.
std::optional<Box> ClippedBox(const cv::Rect2d& rect, const cv::Rect2d& frame, std::string label,
                              float confidence);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_DETECTORS_DETECTOR_INPUT_H_

#include "server/visual_slam/detectors/detector_input.h"

#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace waymark::visual_slam {

std::string ExceptionMessage(const std::exception& e) {
  return std::string(absl::StripTrailingAsciiWhitespace(e.what()));
}

absl::StatusOr<std::vector<Box>> DetectGuarded(
    absl::string_view detector, const cv::Mat& image, int channels,
    const std::function<absl::StatusOr<std::vector<Box>>(const cv::Mat& converted)>& detect) {
  if (image.empty()) return absl::InvalidArgumentError(absl::StrCat(detector, ": empty image"));
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    return absl::InvalidArgumentError(
        absl::StrCat(detector, ": the image must be 8-bit gray or BGR"));
  }
  try {
    cv::Mat converted;
    if (image.channels() == channels) {
      converted = image;
    } else {
      cv::cvtColor(image, converted, channels == 1 ? cv::COLOR_BGR2GRAY : cv::COLOR_GRAY2BGR);
    }
    return detect(converted);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat(detector, ": OpenCV failed: ", ExceptionMessage(e)));
  } catch (const std::exception& e) {  // std::bad_alloc on a huge frame
    return absl::InternalError(absl::StrCat(detector, ": ", ExceptionMessage(e)));
  }
}

std::optional<Box> ClippedBox(const cv::Rect2d& rect, const cv::Rect2d& frame, std::string label,
                              float confidence) {
  const cv::Rect2d clipped = rect & frame;
  if (clipped.width <= 0 || clipped.height <= 0) return std::nullopt;
  Box box;
  box.x = static_cast<float>(clipped.x);
  box.y = static_cast<float>(clipped.y);
  box.w = static_cast<float>(clipped.width);
  box.h = static_cast<float>(clipped.height);
  box.label = std::move(label);
  box.confidence = confidence;
  return box;
}

}  // namespace waymark::visual_slam

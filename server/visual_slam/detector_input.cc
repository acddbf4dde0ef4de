#include "server/visual_slam/detector_input.h"

#include <opencv2/imgproc.hpp>

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

}  // namespace waymark::visual_slam

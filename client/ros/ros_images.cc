#include "client/ros/ros_images.h"

#include <algorithm>
#include <climits>
#include <cstring>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace waymark::ros {
namespace {

absl::Status ImageError(const MessageOrigin& origin, absl::string_view problem) {
  return absl::InvalidArgumentError(
      absl::StrCat("topic ", origin.topic, " (", origin.type, "): ", problem));
}

struct PixelLayout {
  int cv_type = 0;          // of the rows as stored
  int bytes_per_pixel = 0;
  int color_conversion = -1;  // cv::cvtColor code to BGR / gray, -1 = none
  int element_bytes = 1;    // for the big-endian swap
};

bool LayoutOf(const std::string& encoding, PixelLayout* layout) {
  if (encoding == "mono8" || encoding == "8UC1") {
    *layout = {CV_8UC1, 1, -1, 1};
  } else if (encoding == "bgr8") {
    *layout = {CV_8UC3, 3, -1, 1};
  } else if (encoding == "rgb8") {
    *layout = {CV_8UC3, 3, cv::COLOR_RGB2BGR, 1};
  } else if (encoding == "bgra8") {
    *layout = {CV_8UC4, 4, cv::COLOR_BGRA2BGR, 1};
  } else if (encoding == "rgba8") {
    *layout = {CV_8UC4, 4, cv::COLOR_RGBA2BGR, 1};
  } else if (encoding == "mono16" || encoding == "16UC1") {
    *layout = {CV_16UC1, 2, -1, 2};
  } else if (encoding == "32FC1") {
    *layout = {CV_32FC1, 4, -1, 4};
  } else {
    return false;
  }
  return true;
}

}  // namespace

absl::StatusOr<cv::Mat> ImageToMat(const ImageMsg& image, const MessageOrigin& origin) {
  PixelLayout layout;
  if (!LayoutOf(image.encoding, &layout)) {
    return ImageError(origin, absl::StrCat("image encoding '", image.encoding,
                                           "' is not read here (mono8, rgb8, bgr8, rgba8, bgra8, "
                                           "mono16, 16UC1 and 32FC1 are)"));
  }
  if (image.width == 0 || image.height == 0) {
    return ImageError(origin, absl::StrCat("empty image (", image.width, " x ", image.height, ")"));
  }
  const uint64_t row_bytes = uint64_t{image.width} * layout.bytes_per_pixel;
  if (image.step < row_bytes) {
    return ImageError(origin, absl::StrCat("step ", image.step, " is shorter than a row of ",
                                           image.width, " ", image.encoding, " pixels (",
                                           row_bytes, " bytes)"));
  }
  const uint64_t needed = uint64_t{image.step} * (image.height - 1) + row_bytes;
  if (image.data.size() < needed) {
    return ImageError(origin, absl::StrCat("data holds ", image.data.size(), " bytes; ",
                                           image.height, " rows of step ", image.step,
                                           " need ", needed));
  }
  cv::Mat rows(static_cast<int>(image.height), static_cast<int>(image.width), layout.cv_type);
  for (uint32_t r = 0; r < image.height; ++r) {
    std::memcpy(rows.ptr(static_cast<int>(r)), image.data.data() + uint64_t{r} * image.step,
                row_bytes);
  }
  if (image.is_bigendian && layout.element_bytes > 1) {
    for (int r = 0; r < rows.rows; ++r) {
      uint8_t* p = rows.ptr<uint8_t>(r);
      for (uint64_t i = 0; i + layout.element_bytes <= row_bytes; i += layout.element_bytes) {
        std::reverse(p + i, p + i + layout.element_bytes);
      }
    }
  }
  if (layout.color_conversion < 0) return rows;
  cv::Mat converted;
  cv::cvtColor(rows, converted, layout.color_conversion);
  return converted;
}

absl::StatusOr<cv::Mat> CompressedImageToMat(const CompressedImageMsg& image,
                                             const MessageOrigin& origin) {
  const std::string format = absl::AsciiStrToLower(image.format);
  if (absl::StrContains(format, "compresseddepth")) {
    return ImageError(origin, absl::StrCat("compressed image format '", image.format,
                                           "' (compressedDepth) is not read here; jpeg and png "
                                           "are"));
  }
  if (image.data.empty()) return ImageError(origin, "compressed image with no data");
  if (image.data.size() > static_cast<size_t>(INT_MAX)) {
    return ImageError(origin, "compressed image over 2 GB");
  }
  try {
    const cv::Mat buffer(1, static_cast<int>(image.data.size()), CV_8UC1,
                         const_cast<char*>(image.data.data()));
    cv::Mat decoded = cv::imdecode(buffer, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
    if (decoded.empty()) {
      return ImageError(origin, absl::StrCat("cannot decode the ", image.data.size(),
                                             "-byte compressed image (format '", image.format,
                                             "'): not a JPEG or PNG OpenCV reads"));
    }
    if (decoded.channels() == 4) cv::cvtColor(decoded, decoded, cv::COLOR_BGRA2BGR);
    return decoded;
  } catch (const cv::Exception& e) {
    return ImageError(origin, absl::StrCat("decoding the compressed image (format '",
                                           image.format, "'): ", e.what()));
  }
}

}  // namespace waymark::ros

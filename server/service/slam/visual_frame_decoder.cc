#include "server/service/slam/visual_frame_decoder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "server/common/image_header.h"
#include "server/common/stopwatch.h"
#include "server/service/slam/visual_params.h"

namespace waymark::service {

namespace {

std::string Size(int width, int height) { return absl::StrCat(width, "x", height); }

absl::Status FrameError(uint64_t sequence, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("frame ", sequence, ": ", what));
}

cv::Mat Decode(const std::string& bytes, int flags) {
  // imdecode reads from a Mat header over the bytes: no copy.
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                       const_cast<char*>(bytes.data()));
  try {
    return cv::imdecode(buffer, flags);
  } catch (const cv::Exception&) {
    return cv::Mat();  // OpenCV throws on some truncated files instead of returning empty
  }
}

}  // namespace

absl::StatusOr<DecodedFrame> DecodeFrame(const v1::ImageFrame& frame, uint64_t sequence,
                                         const visual_slam::CameraModel& camera) {
  const auto start = std::chrono::steady_clock::now();
  if (!std::isfinite(frame.stamp())) return FrameError(sequence, "stamp is not a finite number");
  if (frame.image().empty()) return FrameError(sequence, "image is empty (send JPEG or PNG bytes)");
  const std::string camera_size = Size(camera.width, camera.height);
  std::optional<ImageHeader> header = ReadImageHeader(frame.image());
  if (!header.has_value()) return FrameError(sequence, "image does not decode as JPEG/PNG");
  if (header->width != camera.width || header->height != camera.height) {
    return FrameError(sequence, absl::StrCat("image is ", Size(header->width, header->height),
                                             " but the session's camera is ", camera_size));
  }
  if (frame.boxes_size() > kMaxFrameBoxes) {
    return FrameError(sequence, absl::StrCat(frame.boxes_size(), " boxes; at most ",
                                             kMaxFrameBoxes));
  }
  DecodedFrame decoded;
  decoded.want_features = frame.want_features();
  visual_slam::FrameInput& input = decoded.input;
  input.stamp = frame.stamp();
  if (frame.boxes_supplied() || frame.boxes_size() > 0) {
    std::vector<visual_slam::Box> boxes;
    boxes.reserve(static_cast<size_t>(frame.boxes_size()));
    for (int i = 0; i < frame.boxes_size(); ++i) {
      absl::StatusOr<visual_slam::Box> box = FromProtoBox(frame.boxes(i));
      if (!box.ok()) return FrameError(sequence, absl::StrCat("box ", i, ": ", box.status().message()));
      boxes.push_back(*std::move(box));
    }
    input.boxes = std::move(boxes);
  }
  if (!frame.depth().empty()) {
    std::optional<ImageHeader> depth_header = ReadImageHeader(frame.depth());
    if (!depth_header.has_value() || !depth_header->png || depth_header->png_bit_depth != 16 ||
        depth_header->png_colour_type != 0) {
      std::string got = "not a PNG";
      if (depth_header.has_value() && depth_header->png) {
        got = absl::StrCat("a ", depth_header->png_bit_depth, "-bit PNG of colour type ",
                           depth_header->png_colour_type);
      } else if (depth_header.has_value()) {
        got = "a JPEG";
      }
      return FrameError(sequence, absl::StrCat("depth must be a 16-bit single-channel PNG, got ",
                                               got));
    }
    if (depth_header->width != camera.width || depth_header->height != camera.height) {
      return FrameError(sequence,
                        absl::StrCat("depth is ", Size(depth_header->width, depth_header->height),
                                     " but the session's camera is ", camera_size));
    }
    input.depth = Decode(frame.depth(), cv::IMREAD_UNCHANGED);
    if (input.depth.empty()) return FrameError(sequence, "depth does not decode as PNG");
    if (input.depth.type() != CV_16UC1) {
      return FrameError(sequence, "depth must be a 16-bit single-channel PNG");
    }
  }
  // ANYCOLOR keeps gray images gray (the engine takes 8-bit gray or BGR) and drops alpha.
  input.image = Decode(frame.image(), cv::IMREAD_ANYCOLOR);
  if (input.image.empty()) return FrameError(sequence, "image does not decode as JPEG/PNG");
  if (input.image.cols != camera.width || input.image.rows != camera.height) {
    return FrameError(sequence, absl::StrCat("image is ", Size(input.image.cols, input.image.rows),
                                             " but the session's camera is ", camera_size));
  }
  if (input.image.depth() != CV_8U ||
      (input.image.channels() != 1 && input.image.channels() != 3)) {
    return FrameError(sequence, "image must be 8-bit gray or colour");
  }
  decoded.bytes = input.image.total() * input.image.elemSize() +
                  input.depth.total() * input.depth.elemSize();
  decoded.decode_ms = MsSince(start);
  return decoded;
}

}  // namespace waymark::service

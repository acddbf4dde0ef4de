#include "server/service/visual_frame_decoder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/service/visual_params.h"

namespace waymark::service {

namespace {

struct ImageHeader {
  int width = 0;
  int height = 0;
  bool png = false;
  int png_bit_depth = 0;
  int png_colour_type = -1;  // 0 gray, 2 RGB, 3 palette, 4 gray + alpha, 6 RGBA
};

uint32_t BigEndian(const std::string& s, size_t at, int bytes) {
  uint32_t value = 0;
  for (int i = 0; i < bytes; ++i) value = (value << 8) | static_cast<unsigned char>(s[at + i]);
  return value;
}

// Size (and PNG pixel format) from the header; nullopt when the bytes are neither a PNG nor a
// JPEG with a frame header.
std::optional<ImageHeader> ReadHeader(const std::string& bytes) {
  static const char kPng[] = "\x89PNG\r\n\x1a\n";
  ImageHeader header;
  if (bytes.size() >= 26 && bytes.compare(0, 8, kPng, 8) == 0 && bytes.compare(12, 4, "IHDR") == 0) {
    header.png = true;
    header.width = static_cast<int>(std::min<uint32_t>(BigEndian(bytes, 16, 4), 1u << 30));
    header.height = static_cast<int>(std::min<uint32_t>(BigEndian(bytes, 20, 4), 1u << 30));
    header.png_bit_depth = static_cast<unsigned char>(bytes[24]);
    header.png_colour_type = static_cast<unsigned char>(bytes[25]);
    return header;
  }
  if (bytes.size() < 4 || static_cast<unsigned char>(bytes[0]) != 0xFF ||
      static_cast<unsigned char>(bytes[1]) != 0xD8) {
    return std::nullopt;
  }
  // JPEG: walk the marker segments to the first start-of-frame (SOF0-SOF15 but DHT C4, JPG C8,
  // DAC CC), whose payload is precision, height, width.
  size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (static_cast<unsigned char>(bytes[at]) != 0xFF) return std::nullopt;
    const unsigned char marker = static_cast<unsigned char>(bytes[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
      at += 2;
      continue;
    }
    const uint32_t length = BigEndian(bytes, at + 2, 2);
    if (length < 2) return std::nullopt;
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (at + 9 > bytes.size()) return std::nullopt;
      header.height = static_cast<int>(BigEndian(bytes, at + 5, 2));
      header.width = static_cast<int>(BigEndian(bytes, at + 7, 2));
      return header;
    }
    if (marker == 0xDA || marker == 0xD9) return std::nullopt;  // scan data before any frame
    at += 2 + length;
  }
  return std::nullopt;
}

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
  std::optional<ImageHeader> header = ReadHeader(frame.image());
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
    std::optional<ImageHeader> depth_header = ReadHeader(frame.depth());
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

#include "server/visual_slam/frame_validation.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/common/input_bounds.h"

namespace waymark::visual_slam {
namespace {

// Bounds beyond which a number is a corrupt message, not a camera: a focal length this many
// times the image's larger side (a field of view under 0.6 degrees), a distortion coefficient
// this large (lenses measure below 10), a box this many image sides from the image. Stamps:
// server/common/input_bounds.h.
constexpr double kMaxFocalPerSide = 100;
constexpr double kMaxDistortion = 1000;
constexpr double kMaxBoxSides = 10;

}  // namespace

absl::Status ValidateCamera(const CameraModel& camera) {
  const bool finite = std::isfinite(camera.fx) && std::isfinite(camera.fy) &&
                      std::isfinite(camera.cx) && std::isfinite(camera.cy);
  const double max_focal = kMaxFocalPerSide * std::max(camera.width, camera.height);
  if (!finite || camera.fx <= 0 || camera.fy <= 0 || camera.fx > max_focal ||
      camera.fy > max_focal) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera: focal lengths must be positive, finite and at most ", kMaxFocalPerSide,
        " times the image's larger side, got fx=", camera.fx, " fy=", camera.fy));
  }
  if (camera.width < 16 || camera.height < 16 || camera.width > 8192 || camera.height > 8192) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera: image size must be 16..8192 pixels, got ", camera.width, "x", camera.height));
  }
  if (!(camera.cx >= 0 && camera.cx <= camera.width && camera.cy >= 0 &&
        camera.cy <= camera.height)) {
    return absl::InvalidArgumentError(absl::StrCat("camera: principal point (", camera.cx, ", ",
                                                   camera.cy, ") lies outside the ", camera.width,
                                                   "x", camera.height, " image"));
  }
  for (double k : camera.distortion) {
    if (!std::isfinite(k) || std::abs(k) > kMaxDistortion) {
      return absl::InvalidArgumentError(
          absl::StrCat("camera: distortion coefficients must be finite and within +-",
                       kMaxDistortion, ", got ", k));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateFrame(const FrameInput& frame, const CameraModel& camera,
                           std::optional<double> last_stamp, std::optional<bool> with_depth) {
  if (!PlausibleStamp(frame.stamp)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frame stamp must be a finite time (|stamp| <= ", kMaxAbsStampS, " s), got ", frame.stamp));
  }
  if (last_stamp && !(frame.stamp > *last_stamp)) {
    return absl::InvalidArgumentError(absl::StrCat("frame stamp ", frame.stamp,
                                                   " is not after the last frame's ", *last_stamp,
                                                   " (frames must come in time order)"));
  }
  const cv::Mat& image = frame.image;
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    return absl::InvalidArgumentError("frame image must be 8-bit gray or 3-channel colour");
  }
  if (image.cols != camera.width || image.rows != camera.height) {
    return absl::InvalidArgumentError(absl::StrCat("frame image is ", image.cols, "x", image.rows,
                                                   " but the session's camera is ", camera.width,
                                                   "x", camera.height));
  }
  if (!frame.depth.empty()) {
    if (frame.depth.type() != CV_16UC1) {
      return absl::InvalidArgumentError("depth image must be 16-bit single channel");
    }
    if (frame.depth.cols != camera.width || frame.depth.rows != camera.height) {
      return absl::InvalidArgumentError(
          absl::StrCat("depth image is ", frame.depth.cols, "x", frame.depth.rows,
                       " but the session's camera is ", camera.width, "x", camera.height));
    }
  }
  if (with_depth && *with_depth != !frame.depth.empty()) {
    return absl::InvalidArgumentError(
        *with_depth ? "this session is RGB-D (its first frame had depth): every frame needs depth"
                    : "this session is monocular (its first frame had no depth): frames cannot "
                      "add depth later");
  }
  if (frame.boxes) {
    const double reach = kMaxBoxSides * std::max(camera.width, camera.height);
    for (const Box& box : *frame.boxes) {
      if (!std::isfinite(box.x) || !std::isfinite(box.y) || !std::isfinite(box.w) ||
          !std::isfinite(box.h) || box.w < 0 || box.h < 0 || std::abs(box.x) > reach ||
          std::abs(box.y) > reach || box.w > reach || box.h > reach) {
        return absl::InvalidArgumentError(absl::StrCat(
            "box (", box.x, ", ", box.y, ", ", box.w, ", ", box.h,
            ") must be finite with a non-negative size, within ", reach, " pixels of the image"));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace waymark::visual_slam

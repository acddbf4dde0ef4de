#include "server/visual_slam/camera_check.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::visual_slam {

std::vector<std::string> CameraWarnings(const CameraModel& c) {
  std::vector<std::string> out;
  if (c.width <= 0 || c.height <= 0) return out;
  const double w = c.width, h = c.height;
  const std::string size = absl::StrCat(c.width, "x", c.height);
  if (c.cx < 0 || c.cx > w || c.cy < 0 || c.cy > h) {
    out.push_back(absl::StrFormat(
        "camera: the principal point (%.1f, %.1f) lies outside the %s images: intrinsics of "
        "another camera or image size?",
        c.cx, c.cy, size));
  } else if (std::abs(c.cx - 0.5 * w) > kMaxPrincipalOffset * w ||
             std::abs(c.cy - 0.5 * h) > kMaxPrincipalOffset * h) {
    out.push_back(absl::StrFormat(
        "camera: the principal point (%.1f, %.1f) is far from the centre (%.1f, %.1f) of the %s "
        "images (more than %.0f %% of a side): intrinsics of another camera or image size?",
        c.cx, c.cy, 0.5 * w, 0.5 * h, size, 100 * kMaxPrincipalOffset));
  }
  const double lo = kMinFocalPerWidth * w, hi = kMaxFocalPerWidth * w;
  for (const auto& [name, f] : {std::pair<const char*, double>{"fx", c.fx}, {"fy", c.fy}}) {
    if (f < lo || f > hi) {
      out.push_back(absl::StrFormat(
          "camera: %s %.1f px is implausible for %s images (expected %.0f-%.0f px, a horizontal "
          "field of view of %.0f-%.0f degrees)",
          name, f, size, lo, hi, 2 * std::atan(0.5 / kMaxFocalPerWidth) * 180 / M_PI,
          2 * std::atan(0.5 / kMinFocalPerWidth) * 180 / M_PI));
    }
  }
  if (c.fx > 0 && c.fy > 0 && (c.fx / c.fy > kMaxAspect || c.fy / c.fx > kMaxAspect)) {
    out.push_back(absl::StrFormat("camera: fx %.1f and fy %.1f differ by more than %.0f %%", c.fx,
                                  c.fy, 100 * (kMaxAspect - 1)));
  }
  return out;
}

}  // namespace waymark::visual_slam

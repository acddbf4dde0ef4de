#include "server/visual_slam/detectors/hog_people_detector.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <optional>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/visual_slam/detectors/detector_input.h"

namespace waymark::visual_slam {
namespace {

// The default people detector's window.
constexpr int kWindowWidth = 64;
constexpr int kWindowHeight = 128;

class HogPeopleDetector : public ObjectDetector {
 public:
  explicit HogPeopleDetector(const HogOptions& options) : options_(options) {
    hog_.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  }

  std::string name() const override { return "hog"; }

  absl::StatusOr<std::vector<Box>> Detect(const cv::Mat& image) override {
    return DetectGuarded("hog", image, 1,
                         [&](const cv::Mat& converted) { return DetectGray(converted); });
  }

 private:
  // The detection proper on the checked gray image (DetectGuarded).
  absl::StatusOr<std::vector<Box>> DetectGray(cv::Mat gray) {
    const cv::Rect2d frame(0, 0, gray.cols, gray.rows);  // boxes are clipped to the input
    double shrink = 1;                                   // original pixels per working pixel
    if (options_.max_width > 0 && gray.cols > options_.max_width) {
      shrink = static_cast<double>(gray.cols) / options_.max_width;
      cv::Mat small;
      cv::resize(
          gray, small,
          cv::Size(options_.max_width, std::max(1, static_cast<int>(gray.rows / shrink + 0.5))), 0,
          0, cv::INTER_AREA);
      gray = small;
    }
    std::vector<Box> boxes;
    // Smaller than one window: nothing can be found (and OpenCV would assert).
    if (gray.cols < kWindowWidth || gray.rows < kWindowHeight) return boxes;
    std::vector<cv::Rect> found;
    std::vector<double> weights;
    hog_.detectMultiScale(gray, found, weights, options_.hit_threshold,
                          cv::Size(options_.win_stride, options_.win_stride), cv::Size(0, 0),
                          options_.scale, options_.group_threshold);
    for (size_t i = 0; i < found.size(); ++i) {
      const cv::Rect2d r(found[i].x * shrink, found[i].y * shrink, found[i].width * shrink,
                         found[i].height * shrink);
      // The SVM margin of the grouped window (not a probability; larger = surer).
      const float margin = i < weights.size() ? static_cast<float>(weights[i]) : 1.0f;
      if (std::optional<Box> box = ClippedBox(r, frame, "person", margin)) {
        boxes.push_back(*std::move(box));
      }
    }
    return boxes;
  }

  HogOptions options_;
  cv::HOGDescriptor hog_;  // default: 64x128 window, 8x8 cells, 9 bins
};

}  // namespace

absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeHogPeopleDetector(const HogOptions& options) {
  if (options.win_stride <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("hog: win_stride is ", options.win_stride, "; it must be positive"));
  }
  if (!(options.scale > 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("hog: scale is ", options.scale, "; it must be above 1"));
  }
  if (options.group_threshold < 0) {
    return absl::InvalidArgumentError("hog: group_threshold must not be negative");
  }
  if (options.max_width != 0 && options.max_width < kWindowWidth) {
    return absl::InvalidArgumentError(absl::StrCat(
        "hog: max_width is ", options.max_width, "; 0 (never shrink) or at least ", kWindowWidth));
  }
  if (!std::isfinite(options.hit_threshold)) {
    return absl::InvalidArgumentError("hog: hit_threshold must be finite");
  }
  return std::make_unique<HogPeopleDetector>(options);
}

}  // namespace waymark::visual_slam

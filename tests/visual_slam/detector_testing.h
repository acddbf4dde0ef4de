#ifndef WAYMARK_TESTS_VISUAL_SLAM_DETECTOR_TESTING_H_
#define WAYMARK_TESTS_VISUAL_SLAM_DETECTOR_TESTING_H_

// Helpers the detector tests share: skipping without ../shared, and unwrapping a factory's or
// Detect()'s StatusOr into a test failure instead of a crash.

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/detectors/object_detector.h"
#include "server/visual_slam/types.h"

// Ends the test as skipped when `path` (under ../shared) is absent.
#define SKIP_WITHOUT(path)                                                     \
  if (!std::filesystem::exists(path)) {                                        \
    GTEST_SKIP() << "no " << (path) << " (../shared absent): nothing to test"; \
  }

namespace waymark::visual_slam::testing {

// The detector a factory made; a test failure and nullptr when the factory refused.
inline std::unique_ptr<ObjectDetector> DetectorOrDie(
    absl::StatusOr<std::unique_ptr<ObjectDetector>> detector) {
  EXPECT_TRUE(detector.ok()) << detector.status();
  return detector.ok() ? *std::move(detector) : nullptr;
}

// The boxes found in `image` (which must have been read); a test failure and none on an error.
inline std::vector<Box> DetectOrDie(ObjectDetector& detector, const cv::Mat& image) {
  EXPECT_FALSE(image.empty());
  auto boxes = detector.Detect(image);
  EXPECT_TRUE(boxes.ok()) << boxes.status();
  return boxes.ok() ? *boxes : std::vector<Box>{};
}

}  // namespace waymark::visual_slam::testing

#endif  // WAYMARK_TESTS_VISUAL_SLAM_DETECTOR_TESTING_H_

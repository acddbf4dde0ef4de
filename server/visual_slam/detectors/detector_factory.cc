#include "server/visual_slam/detectors/detector_factory.h"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::visual_slam {

absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeDetector(const DetectorChoice& choice) {
  switch (choice.kind) {
    case DetectorChoice::kNone:
      return std::unique_ptr<ObjectDetector>();
    case DetectorChoice::kYolo:
      return MakeYoloDetector(choice.yolo);
    case DetectorChoice::kHog:
      return MakeHogPeopleDetector(choice.hog);
  }
  return absl::InvalidArgumentError(
      absl::StrCat("detector: unknown kind ", static_cast<int>(choice.kind)));
}

}  // namespace waymark::visual_slam

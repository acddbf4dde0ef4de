// MakeDetector builds what the session chose, or nothing, or the chosen detector's error.

#include "server/visual_slam/detectors/detector_factory.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace waymark::visual_slam {
namespace {

const std::string kModelDir = WAYMARK_SHARED_DIR "/models/yolo-fastest-1.1-coco/";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(MakeDetector, NoneIsANullDetector) {
  auto detector = MakeDetector(DetectorChoice{});
  ASSERT_TRUE(detector.ok()) << detector.status();
  EXPECT_EQ(*detector, nullptr);
}

TEST(MakeDetector, HogNeedsNoModel) {
  DetectorChoice choice;
  choice.kind = DetectorChoice::kHog;
  auto detector = MakeDetector(choice);
  ASSERT_TRUE(detector.ok()) << detector.status();
  ASSERT_NE(*detector, nullptr);
  EXPECT_EQ((*detector)->name(), "hog");
}

TEST(MakeDetector, PassesTheDetectorsErrorsOn) {
  DetectorChoice yolo;
  yolo.kind = DetectorChoice::kYolo;  // no model bytes
  EXPECT_EQ(MakeDetector(yolo).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(MakeDetector(yolo).status().message()), ::testing::HasSubstr("no model"));
  DetectorChoice hog;
  hog.kind = DetectorChoice::kHog;
  hog.hog.scale = 0.5;
  EXPECT_EQ(MakeDetector(hog).status().code(), absl::StatusCode::kInvalidArgument);
  DetectorChoice unknown;
  unknown.kind = static_cast<DetectorChoice::Kind>(7);
  EXPECT_EQ(MakeDetector(unknown).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(MakeDetector, YoloFromModelBytes) {
  if (!std::filesystem::exists(kModelDir + "yolo-fastest-1.1-xl.weights")) {
    GTEST_SKIP() << "no " << kModelDir << " (../shared absent): nothing to test";
  }
  DetectorChoice choice;
  choice.kind = DetectorChoice::kYolo;
  choice.yolo.cfg = ReadFile(kModelDir + "yolo-fastest-1.1-xl.cfg");
  choice.yolo.weights = ReadFile(kModelDir + "yolo-fastest-1.1-xl.weights");
  auto detector = MakeDetector(choice);
  ASSERT_TRUE(detector.ok()) << detector.status();
  ASSERT_NE(*detector, nullptr);
  EXPECT_EQ((*detector)->name(), "yolo");
}

}  // namespace
}  // namespace waymark::visual_slam

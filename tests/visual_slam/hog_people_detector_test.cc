// HogPeopleDetector on real frames against boxes judged by eye (frame pixels), the downscaling of
// wide frames, and bad options.

#include "server/visual_slam/detectors/hog_people_detector.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "tests/visual_slam/detector_testing.h"

namespace waymark::visual_slam {
namespace {

using ::waymark::visual_slam::testing::DetectOrDie;
using ::waymark::visual_slam::testing::DetectorOrDie;

const std::string kVslam = WAYMARK_SHARED_DIR "/data/vslam/";
// Bonn crowd frame 380: a man seen from behind, upright and whole, 365 px tall.
const std::string kBonn380 = kVslam + "bonn_rgbd_crowd_frames270-409/rgb/1548339832.61140.png";
// TUM fr3/walking_xyz: the office with nobody in it.
const std::string kTumNobody = kVslam + "tum_fr3_walking_xyz_3frames/rgb/1341846325.417931.png";
const cv::Rect2d kBonn380Man(175, 45, 110, 365);  // by eye

std::unique_ptr<ObjectDetector> MakeOrDie(const HogOptions& options) {
  return DetectorOrDie(MakeHogPeopleDetector(options));
}

double IoU(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

cv::Rect2d Rect(const Box& b) { return cv::Rect2d(b.x, b.y, b.w, b.h); }

// The box best overlapping `truth` (IoU 0 and an empty box if none).
std::pair<double, cv::Rect2d> Best(const std::vector<Box>& boxes, const cv::Rect2d& truth) {
  std::pair<double, cv::Rect2d> best{0, cv::Rect2d()};
  for (const Box& b : boxes) {
    if (IoU(Rect(b), truth) > best.first) best = {IoU(Rect(b), truth), Rect(b)};
  }
  return best;
}

TEST(HogPeopleDetector, FindsTheUprightManOnBonn) {
  SKIP_WITHOUT(kBonn380);
  auto detector = MakeOrDie(HogOptions{});
  ASSERT_NE(detector, nullptr);
  EXPECT_EQ(detector->name(), "hog");
  const cv::Mat image = cv::imread(kBonn380, cv::IMREAD_COLOR);
  const auto boxes = DetectOrDie(*detector, image);
  ASSERT_FALSE(boxes.empty());
  for (const Box& b : boxes) {
    EXPECT_EQ(b.label, "person");
    EXPECT_GE(b.x, 0);
    EXPECT_GE(b.y, 0);
    EXPECT_LE(b.x + b.w, image.cols + 1e-3);
    EXPECT_LE(b.y + b.h, image.rows + 1e-3);
  }
  // HOG's window has a margin around the body: the box is wider than the man, so the bar is an
  // IoU of 0.4 and the man's centre inside it.
  const auto [iou, box] = Best(boxes, kBonn380Man);
  EXPECT_GE(iou, 0.4);
  EXPECT_TRUE(box.contains(
      cv::Point2d(kBonn380Man.x + kBonn380Man.width / 2, kBonn380Man.y + kBonn380Man.height / 2)));
}

TEST(HogPeopleDetector, NothingInTheEmptyOffice) {
  SKIP_WITHOUT(kTumNobody);
  auto detector = MakeOrDie(HogOptions{});
  ASSERT_NE(detector, nullptr);
  EXPECT_THAT(DetectOrDie(*detector, cv::imread(kTumNobody, cv::IMREAD_COLOR)),
              ::testing::IsEmpty());
}

TEST(HogPeopleDetector, WideFramesAreShrunkAndBoxesComeBackInFramePixels) {
  SKIP_WITHOUT(kBonn380);
  const cv::Mat image = cv::imread(kBonn380, cv::IMREAD_GRAYSCALE);  // gray works too
  cv::Mat doubled;
  cv::resize(image, doubled, image.size() * 2, 0, 0, cv::INTER_LINEAR);
  auto detector = MakeOrDie(HogOptions{});  // max_width 640: the 1280 frame is halved
  ASSERT_NE(detector, nullptr);
  const auto [iou, box] = Best(DetectOrDie(*detector, doubled),
                               cv::Rect2d(kBonn380Man.x * 2, kBonn380Man.y * 2,
                                          kBonn380Man.width * 2, kBonn380Man.height * 2));
  EXPECT_GE(iou, 0.4);
  // Same man, same place as on the 640 frame, in the doubled frame's pixels.
  const auto [iou640, box640] = Best(DetectOrDie(*detector, image), kBonn380Man);
  EXPECT_GE(IoU(box, cv::Rect2d(box640.x * 2, box640.y * 2, box640.width * 2, box640.height * 2)),
            0.8);
}

TEST(HogPeopleDetector, TinyBlackAndBadImages) {
  auto detector = MakeOrDie(HogOptions{});
  ASSERT_NE(detector, nullptr);
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(128))),
              ::testing::IsEmpty());
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat::zeros(480, 640, CV_8UC3)), ::testing::IsEmpty());
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat::zeros(100, 2000, CV_8UC1)), ::testing::IsEmpty());
  EXPECT_EQ(detector->Detect(cv::Mat()).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(detector->Detect(cv::Mat::zeros(200, 200, CV_32FC1)).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(MakeHogPeopleDetector, RefusesBadOptions) {
  auto expect_invalid = [](HogOptions options, const std::string& what) {
    auto detector = MakeHogPeopleDetector(options);
    ASSERT_FALSE(detector.ok()) << what;
    EXPECT_EQ(detector.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(detector.status().message()), ::testing::HasSubstr(what));
  };
  HogOptions o;
  o.win_stride = 0;
  expect_invalid(o, "win_stride");
  o = HogOptions{};
  o.scale = 1.0;
  expect_invalid(o, "scale");
  o = HogOptions{};
  o.group_threshold = -1;
  expect_invalid(o, "group_threshold");
  o = HogOptions{};
  o.max_width = 32;
  expect_invalid(o, "max_width");
  o = HogOptions{};
  o.hit_threshold = std::nan("");
  expect_invalid(o, "hit_threshold");
}

}  // namespace
}  // namespace waymark::visual_slam

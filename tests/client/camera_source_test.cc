#include "client/devices/camera_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "tests/client/test_util.h"

namespace waymark::client {
namespace {

using ::testing::HasSubstr;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

TEST(ClassifySourceTest, TellsKindsApart) {
  EXPECT_EQ(ClassifySource("0"), SourceKind::kDevice);
  EXPECT_EQ(ClassifySource("12"), SourceKind::kDevice);
  EXPECT_EQ(ClassifySource("rtsp://robot/cam"), SourceKind::kStreamUrl);
  EXPECT_EQ(ClassifySource("frames/%04d.png"), SourceKind::kImageSequence);
  EXPECT_EQ(ClassifySource("img_%d.jpg"), SourceKind::kImageSequence);
  EXPECT_EQ(ClassifySource("drive.mp4"), SourceKind::kVideoFile);
  EXPECT_EQ(ClassifySource("0.avi"), SourceKind::kVideoFile);
}

// Decodes a frame and returns its size; fails the test if it is not a JPEG.
cv::Size DecodeJpeg(const std::string& bytes) {
  EXPECT_GE(bytes.size(), 3u);
  EXPECT_EQ(bytes.substr(0, 3), std::string("\xFF\xD8\xFF"));  // JPEG magic
  cv::Mat image = cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty());
  return image.size();
}

class ImageSequenceTest : public ::testing::TestWithParam<int> {};

TEST_P(ImageSequenceTest, FramesComeOutResizedAsJpegThenEnd) {
  const int first = GetParam();
  ScopedTempDir dir;
  for (int i = first; i < first + 3; ++i) {
    WriteImage(dir.Make(cv::format("frames/%04d.png", i)), 640, 480, cv::Scalar(20 * i, 90, 200));
  }
  auto camera = CameraSource::Open((dir.path() / "frames/%04d.png").string());
  ASSERT_TRUE(camera.ok()) << camera.status();
  EXPECT_EQ((*camera)->kind(), SourceKind::kImageSequence);
  for (int i = 0; i < 3; ++i) {
    auto frame = (*camera)->Next();
    ASSERT_TRUE(frame.ok()) << "frame " << i << ": " << frame.status();
    EXPECT_EQ(DecodeJpeg(*frame), cv::Size(320, 240));
  }
  auto end = (*camera)->Next();
  EXPECT_EQ(end.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(end.status().message(), HasSubstr("after 3 frames"));
  EXPECT_EQ((*camera)->frames_read(), 3);
}

INSTANTIATE_TEST_SUITE_P(StartIndex, ImageSequenceTest, ::testing::Values(0, 1));

TEST(CameraSourceTest, SizeAndQualityOptions) {
  ScopedTempDir dir;
  WriteImage(dir.Make("f/000.png"), 64, 48, cv::Scalar(10, 200, 30));
  WriteImage(dir.Make("f/001.png"), 64, 48, cv::Scalar(10, 200, 30));

  CameraSourceOptions keep;
  keep.width = 0;
  keep.jpeg_quality = 100;
  auto original = CameraSource::Open((dir.path() / "f/%03d.png").string(), keep);
  ASSERT_TRUE(original.ok()) << original.status();
  auto best = (*original)->Next();
  ASSERT_TRUE(best.ok());
  EXPECT_EQ(DecodeJpeg(*best), cv::Size(64, 48));

  CameraSourceOptions small;
  small.width = 32;
  small.height = 16;
  small.jpeg_quality = 5;
  auto resized = CameraSource::Open((dir.path() / "f/%03d.png").string(), small);
  ASSERT_TRUE(resized.ok());
  auto worst = (*resized)->Next();
  ASSERT_TRUE(worst.ok());
  EXPECT_EQ(DecodeJpeg(*worst), cv::Size(32, 16));
}

TEST(CameraSourceTest, ClearErrorsWhenTheSourceCannotBeOpened) {
  ScopedTempDir dir;
  auto missing_file = CameraSource::Open((dir.path() / "drive.mp4").string());
  EXPECT_EQ(missing_file.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing_file.status().message(), HasSubstr("drive.mp4"));

  auto missing_dir = CameraSource::Open((dir.path() / "nope/%04d.png").string());
  EXPECT_EQ(missing_dir.status().code(), absl::StatusCode::kNotFound);

  std::filesystem::create_directories(dir.path() / "empty");
  auto empty_sequence = CameraSource::Open((dir.path() / "empty/%04d.png").string());
  EXPECT_EQ(empty_sequence.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(empty_sequence.status().message(), HasSubstr("%04d.png"));

  std::ofstream(dir.Make("junk.avi")) << "this is not a video";
  auto junk = CameraSource::Open((dir.path() / "junk.avi").string());
  EXPECT_EQ(junk.status().code(), absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(CameraSource::Open("").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(CameraSourceTest, RejectsBadOptions) {
  CameraSourceOptions quality;
  quality.jpeg_quality = 101;
  EXPECT_EQ(CameraSource::Open("0", quality).status().code(), absl::StatusCode::kInvalidArgument);
  CameraSourceOptions size;
  size.width = -1;
  EXPECT_EQ(CameraSource::Open("0", size).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace waymark::client

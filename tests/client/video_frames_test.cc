// Frames of a crossing video for `waymark enroll --video`: sampled evenly in time, blurry and
// unchanged frames skipped, the step widened under --max-frames, and unreadable or truncated
// files reported as such. The videos are written by the test (Motion-JPEG AVI).
#include "client/datasets/video_frames.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using waymark::testing::BlockFrame;
using waymark::testing::ReadAll;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteVideo;

constexpr double kFps = 10;

// 4 s at 10 fps: the view moves 16 px a frame, except that frame 10 is badly blurred and the robot
// stands still from frame 15 to 25.
std::vector<cv::Mat> Drive() {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 40; ++i) {
    const int moved = i < 15 ? i : (i <= 25 ? 15 : i - 10);
    cv::Mat frame = BlockFrame(16 * moved);
    if (i == 10) cv::GaussianBlur(frame, frame, cv::Size(0, 0), 12);
    frames.push_back(frame);
  }
  return frames;
}

std::vector<double> Times(const VideoSample& sample) {
  std::vector<double> times;
  for (const SampledFrame& frame : sample.frames) times.push_back(frame.t_s);
  return times;
}

TEST(FramePositionTest, IsTheTimeWithoutTrailingZeros) {
  EXPECT_EQ(FramePosition(0), "t=0s");
  EXPECT_EQ(FramePosition(12.5), "t=12.5s");
  EXPECT_EQ(FramePosition(3.25), "t=3.25s");
  EXPECT_EQ(FramePosition(0.5005), "t=0.5s");  // 29.97 fps
  EXPECT_EQ(FramePosition(10), "t=10s");
}

TEST(SampleVideoTest, TakesOneFrameEveryStepAndSkipsBlurryAndUnchangedOnes) {
  ScopedTempDir dir;
  const auto file = dir.path() / "drive.avi";
  WriteVideo(file, Drive(), kFps);
  VideoSampling options;
  options.every_s = 0.5;
  int calls = 0;
  absl::StatusOr<VideoSample> sample =
      SampleVideo(file, options, [&](const VideoSample&) { ++calls; });
  ASSERT_TRUE(sample.ok()) << sample.status();
  EXPECT_EQ(sample->frames_read, 40);
  EXPECT_EQ(sample->frames_declared, 40);
  EXPECT_FALSE(sample->ended_early);
  // Frames 0, 5, ..., 35 looked at: 10 is blurry, 20 and 25 show what 15 showed.
  EXPECT_EQ(sample->sampled, 8);
  EXPECT_EQ(sample->blurry, 1);
  EXPECT_EQ(sample->unchanged, 2);
  EXPECT_EQ(sample->kept(), 5);
  EXPECT_THAT(Times(*sample), ElementsAre(0, 0.5, 1.5, 3.0, 3.5));
  EXPECT_EQ(calls, 8);
  // Sent as JPEG at the video's size.
  const cv::Mat decoded =
      cv::imdecode(std::vector<uchar>(sample->frames[0].jpeg.begin(), sample->frames[0].jpeg.end()),
                   cv::IMREAD_COLOR);
  EXPECT_EQ(decoded.size(), cv::Size(320, 240));

  options.min_sharpness = 0;
  options.min_change = 0;
  sample = SampleVideo(file, options);
  ASSERT_TRUE(sample.ok()) << sample.status();
  EXPECT_EQ(sample->kept(), 8);
}

TEST(SampleVideoTest, ALongVideoIsSpreadOverMaxFrames) {
  ScopedTempDir dir;
  const auto file = dir.path() / "drive.avi";
  WriteVideo(file, Drive(), kFps);
  VideoSampling options;
  options.every_s = 0.5;
  options.max_frames = 4;
  options.min_sharpness = 0;
  options.min_change = 0;
  absl::StatusOr<VideoSample> sample = SampleVideo(file, options);
  ASSERT_TRUE(sample.ok()) << sample.status();
  EXPECT_DOUBLE_EQ(sample->every_s, 1.0);  // 4 s over 4 frames
  EXPECT_THAT(Times(*sample), ElementsAre(0, 1, 2, 3));
}

TEST(SampleVideoTest, MissingAndUndecodableFilesAreErrorsNamingTheFile) {
  ScopedTempDir dir;
  const auto missing = dir.path() / "nowhere.mp4";
  absl::StatusOr<VideoSample> sample = SampleVideo(missing, {});
  EXPECT_EQ(sample.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(sample.status().message(), HasSubstr(missing.string()));

  const auto garbage = dir.Make("garbage.avi");
  std::ofstream(garbage) << std::string(4096, 'x');
  sample = SampleVideo(garbage, {});
  ASSERT_FALSE(sample.ok());
  EXPECT_EQ(sample.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(sample.status().message(), HasSubstr(garbage.string()));

  VideoSampling bad;
  bad.every_s = 0;
  EXPECT_EQ(SampleVideo(garbage, bad).status().code(), absl::StatusCode::kInvalidArgument);
}

// A copy cut off half-way still gives the frames before the cut, and says it ended early.
TEST(SampleVideoTest, ATruncatedVideoEndsEarlyWithTheFramesBeforeTheCut) {
  ScopedTempDir dir;
  const auto file = dir.path() / "drive.avi";
  WriteVideo(file, Drive(), kFps);
  const std::string bytes = ReadAll(file);
  const auto cut = dir.path() / "cut.avi";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  VideoSampling options;
  options.min_sharpness = 0;
  options.min_change = 0;
  absl::StatusOr<VideoSample> sample = SampleVideo(cut, options);
  ASSERT_TRUE(sample.ok()) << sample.status();
  EXPECT_TRUE(sample->ended_early);
  EXPECT_GT(sample->frames_read, 0);
  EXPECT_LT(sample->frames_read, 40);
  EXPECT_EQ(sample->frames_declared, 40);
}

}  // namespace
}  // namespace waymark::cli

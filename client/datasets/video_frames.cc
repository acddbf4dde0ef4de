#include "client/datasets/video_frames.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/devices/camera_source.h"

namespace waymark::cli {
namespace {

// Sharpness is measured at the server's default working width (see the header).
constexpr int kSharpnessWidth = 320;
// Change is measured on a thumbnail this size: small enough to average sensor noise away.
const cv::Size kChangeSize(64, 48);

cv::Mat Grey(const cv::Mat& frame) {
  if (frame.channels() == 1) return frame;
  cv::Mat grey;
  cv::cvtColor(frame, grey, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}

// Variance of the Laplacian of the grey frame at kSharpnessWidth pixels wide.
double Sharpness(const cv::Mat& grey) {
  cv::Mat scaled = grey;
  if (grey.cols != kSharpnessWidth) {
    const int height = std::max(1, grey.rows * kSharpnessWidth / grey.cols);
    cv::resize(grey, scaled, cv::Size(kSharpnessWidth, height), 0, 0, cv::INTER_AREA);
  }
  cv::Mat laplacian;
  cv::Laplacian(scaled, laplacian, CV_64F);
  cv::Scalar mean;
  cv::Scalar stddev;
  cv::meanStdDev(laplacian, mean, stddev);
  return stddev[0] * stddev[0];
}

cv::Mat Thumbnail(const cv::Mat& grey) {
  cv::Mat thumbnail;
  cv::resize(grey, thumbnail, kChangeSize, 0, 0, cv::INTER_AREA);
  return thumbnail;
}

// Mean absolute grey difference of two thumbnails.
double Change(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  return cv::mean(difference)[0];
}

absl::Status ValidateOptions(const VideoSampling& options) {
  if (!(options.every_s >= 0.01 && options.every_s <= 3600)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the sampling step must be in [0.01, 3600] seconds, got ", options.every_s));
  }
  if (options.max_frames < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("the frame limit must be 0 (none) or more, got ", options.max_frames));
  }
  if (!(options.min_sharpness >= 0) || !(options.min_change >= 0)) {
    return absl::InvalidArgumentError("the sharpness and change thresholds must be 0 or more");
  }
  return absl::OkStatus();
}

}  // namespace

std::string FramePosition(double t_s) {
  std::string seconds = fmt::format("{:.2f}", t_s);
  seconds.erase(seconds.find_last_not_of('0') + 1);
  if (seconds.back() == '.') seconds.pop_back();
  return absl::StrCat("t=", seconds, "s");
}

absl::StatusOr<VideoSample> SampleVideo(const std::filesystem::path& file,
                                        const VideoSampling& options,
                                        const VideoProgress& progress) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  const std::string name = file.string();
  if (client::ClassifySource(name) != client::SourceKind::kVideoFile) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", name, "' reads as a ", client::SourceKindName(client::ClassifySource(name)),
        ", not a video file name (give a path such as ./", name, ")"));
  }
  client::CameraSourceOptions camera;
  camera.width = 0;  // the video's own size: the server scales views to its working resolution
  camera.height = 0;
  camera.jpeg_quality = options.jpeg_quality;
  absl::StatusOr<std::unique_ptr<client::CameraSource>> video =
      client::CameraSource::Open(name, camera);
  if (!video.ok()) return video.status();
  client::CameraSource& source = **video;

  VideoSample sample;
  sample.fps = source.fps();
  sample.frames_declared = source.frame_count();
  if (sample.fps <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", name, "' declares no frame rate, so its frames have no times to sample by"));
  }
  sample.every_s = options.every_s;
  if (options.max_frames > 0 && sample.frames_declared > 0) {
    const double duration_s = static_cast<double>(sample.frames_declared) / sample.fps;
    sample.every_s = std::max(sample.every_s, duration_s / options.max_frames);
  }

  // A frame is due when its time reaches the next sampling time, within half a frame (so a step
  // of 0.5 s at 30 fps takes frames 0, 15, 30, ... whatever the rounding of 15 / 30).
  const double half_frame_s = 0.5 / sample.fps;
  double next_s = 0;
  cv::Mat last_kept;
  while (options.max_frames == 0 ||
         static_cast<int>(sample.frames.size()) < options.max_frames) {
    const double t_s = static_cast<double>(sample.frames_read) / sample.fps;
    const bool due = t_s + half_frame_s >= next_s;
    absl::StatusOr<cv::Mat> frame = cv::Mat();
    if (due) {
      frame = source.NextImage();
    } else if (absl::Status skipped = source.Skip(); !skipped.ok()) {
      frame = skipped;
    }
    if (!frame.ok()) {
      if (frame.status().code() == absl::StatusCode::kOutOfRange) break;  // the end
      return frame.status();
    }
    sample.frames_read = source.frames_read();
    if (!due) continue;
    while (next_s <= t_s + half_frame_s) next_s += sample.every_s;
    ++sample.sampled;
    const cv::Mat grey = Grey(*frame);
    const cv::Mat thumbnail = Thumbnail(grey);
    if (options.min_sharpness > 0 && Sharpness(grey) < options.min_sharpness) {
      ++sample.blurry;
    } else if (options.min_change > 0 && !last_kept.empty() &&
               Change(thumbnail, last_kept) < options.min_change) {
      ++sample.unchanged;
    } else {
      absl::StatusOr<std::string> jpeg = source.Encode(*frame);
      if (!jpeg.ok()) return jpeg.status();
      sample.frames.push_back({t_s, *std::move(jpeg)});
      last_kept = thumbnail;
    }
    if (progress) progress(sample);
  }
  if (sample.frames_read == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", name, "' opened as a video but no frame could be decoded: empty or corrupt file?"));
  }
  // Containers estimate their frame count from the duration; a few frames short is no damage.
  const bool stopped_at_limit =
      options.max_frames > 0 && static_cast<int>(sample.frames.size()) >= options.max_frames;
  const int64_t tolerance = std::max<int64_t>(2, sample.frames_declared / 100);
  sample.ended_early = !stopped_at_limit && sample.frames_declared > 0 &&
                       sample.frames_read + tolerance < sample.frames_declared;
  return sample;
}

}  // namespace waymark::cli

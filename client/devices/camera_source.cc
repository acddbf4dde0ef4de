#include "client/devices/camera_source.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::client {
namespace {

namespace fs = std::filesystem;

bool IsAllDigits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

absl::Status ValidateOptions(const CameraSourceOptions& options) {
  if (options.width < 0 || options.height < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("frame size must not be negative, got ", options.width, "x", options.height));
  }
  if (options.jpeg_quality < 0 || options.jpeg_quality > 100) {
    return absl::InvalidArgumentError(
        absl::StrCat("JPEG quality must be in [0, 100], got ", options.jpeg_quality));
  }
  return absl::OkStatus();
}

// Checks what can be checked before OpenCV tries (and fails with a log line instead of a reason).
absl::Status CheckPathExists(const std::string& source, SourceKind kind) {
  std::error_code ec;
  if (kind == SourceKind::kVideoFile && !fs::exists(source, ec)) {
    return absl::NotFoundError(absl::StrCat("video file '", source, "' does not exist"));
  }
  if (kind == SourceKind::kImageSequence) {
    fs::path dir = fs::path(source).parent_path();
    if (!dir.empty() && !fs::is_directory(dir, ec)) {
      return absl::NotFoundError(absl::StrCat("image sequence directory '", dir.string(),
                                              "' does not exist (pattern '", source, "')"));
    }
  }
  return absl::OkStatus();
}

absl::Status OpenError(const std::string& source, SourceKind kind) {
  switch (kind) {
    case SourceKind::kDevice:
      return absl::UnavailableError(absl::StrCat(
          "cannot open camera device ", source,
          " (is it connected, not in use by another program, and readable by this user?)"));
    case SourceKind::kStreamUrl:
      return absl::UnavailableError(absl::StrCat("cannot open stream '", source, "'"));
    case SourceKind::kImageSequence:
      return absl::NotFoundError(
          absl::StrCat("no image matches pattern '", source, "' (numbering must start at 0 or 1)"));
    case SourceKind::kVideoFile:
      break;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("cannot decode video file '", source, "' (unsupported format or codec)"));
}

}  // namespace

SourceKind ClassifySource(const std::string& source) {
  if (IsAllDigits(source)) return SourceKind::kDevice;
  if (source.find("://") != std::string::npos) return SourceKind::kStreamUrl;
  static const std::regex kPattern("%0?[0-9]*d");
  if (std::regex_search(source, kPattern)) return SourceKind::kImageSequence;
  return SourceKind::kVideoFile;
}

const char* SourceKindName(SourceKind kind) {
  switch (kind) {
    case SourceKind::kDevice:
      return "camera device";
    case SourceKind::kStreamUrl:
      return "stream";
    case SourceKind::kImageSequence:
      return "image sequence";
    case SourceKind::kVideoFile:
      return "video file";
  }
  return "source";
}

CameraSource::CameraSource(std::string source, SourceKind kind, const CameraSourceOptions& options)
    : source_(std::move(source)), kind_(kind), options_(options) {}

absl::StatusOr<std::unique_ptr<CameraSource>> CameraSource::Open(
    const std::string& source, const CameraSourceOptions& options) {
  if (source.empty()) return absl::InvalidArgumentError("camera source is empty");
  if (absl::Status status = ValidateOptions(options); !status.ok()) return status;
  const SourceKind kind = ClassifySource(source);
  if (absl::Status status = CheckPathExists(source, kind); !status.ok()) return status;

  std::unique_ptr<CameraSource> camera(new CameraSource(source, kind, options));
  try {
    switch (kind) {
      case SourceKind::kDevice:
        camera->capture_.open(std::stoi(source));
        break;
      case SourceKind::kImageSequence:
        // Pinned to the image backend: others (FFmpeg, GStreamer) would also accept a pattern but
        // differ in which start indices they find.
        camera->capture_.open(source, cv::CAP_IMAGES);
        break;
      case SourceKind::kStreamUrl:
      case SourceKind::kVideoFile:
        camera->capture_.open(source);
        break;
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("OpenCV failed to open '", source, "': ", e.what()));
  } catch (const std::out_of_range&) {
    return absl::InvalidArgumentError(absl::StrCat("camera index '", source, "' is too large"));
  }
  if (!camera->capture_.isOpened()) return OpenError(source, kind);
  return camera;
}

absl::StatusOr<std::string> CameraSource::Next() {
  absl::StatusOr<cv::Mat> frame = NextImage();
  if (!frame.ok()) return frame.status();
  return Encode(*frame);
}

absl::Status CameraSource::EndError() const {
  return absl::OutOfRangeError(absl::StrCat("end of ", SourceKindName(kind_), " '", source_,
                                            "' after ", frames_read_, " frames"));
}

absl::Status CameraSource::Skip() {
  try {
    if (!capture_.grab()) return EndError();
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("OpenCV failed on frame ", frames_read_, " of '", source_, "': ", e.what()));
  }
  ++frames_read_;
  return absl::OkStatus();
}

double CameraSource::fps() const {
  const double fps = capture_.get(cv::CAP_PROP_FPS);
  return std::isfinite(fps) && fps > 0 ? fps : 0;
}

int64_t CameraSource::frame_count() const {
  const double count = capture_.get(cv::CAP_PROP_FRAME_COUNT);
  return std::isfinite(count) && count > 0 ? static_cast<int64_t>(count) : 0;
}

absl::StatusOr<cv::Mat> CameraSource::NextImage() {
  cv::Mat frame;
  try {
    if (!capture_.read(frame) || frame.empty()) return EndError();
    if (options_.width > 0 && options_.height > 0 &&
        (frame.cols != options_.width || frame.rows != options_.height)) {
      cv::Mat resized;
      // INTER_AREA averages pixels when shrinking, which keeps features stable (no aliasing).
      cv::resize(frame, resized, cv::Size(options_.width, options_.height), 0, 0, cv::INTER_AREA);
      frame = resized;
    }
    ++frames_read_;
    return frame;
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("OpenCV failed on frame ", frames_read_, " of '", source_, "': ", e.what()));
  }
}

absl::StatusOr<std::string> CameraSource::Encode(const cv::Mat& frame) const {
  try {
    std::vector<uchar> jpeg;
    if (!cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality})) {
      return absl::InternalError("JPEG encoding failed");
    }
    return std::string(jpeg.begin(), jpeg.end());
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("OpenCV failed to encode a frame of '", source_,
                                            "': ", e.what()));
  }
}

}  // namespace waymark::client

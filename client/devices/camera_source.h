#ifndef WAYMARK_CLIENT_DEVICES_CAMERA_SOURCE_H_
#define WAYMARK_CLIENT_DEVICES_CAMERA_SOURCE_H_

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::client {

// What a SOURCE string names. Decided from the text alone so that errors can say what was tried.
enum class SourceKind {
  kDevice,         // "0", "1": a camera index (V4L2 on Linux)
  kStreamUrl,      // "rtsp://...", "http://...": anything with a scheme
  kImageSequence,  // "frames/%04d.png": a printf pattern; numbering may start at 0 or 1
  kVideoFile,      // anything else: a file OpenCV can decode
};

SourceKind ClassifySource(const std::string& source);
const char* SourceKindName(SourceKind kind);

struct CameraSourceOptions {
  // Frames are resized to exactly this size before encoding; 0 in either keeps the camera's size.
  // The default is the database's default working resolution, so the robot sends no more pixels
  // than the server will use.
  int width = 320;
  int height = 240;
  int jpeg_quality = 90;  // 0-100
};

// Reads frames from a camera, video file, stream or image sequence and hands them out as JPEG bytes
// ready for Image.data. Not thread-safe.
class CameraSource {
 public:
  // NOT_FOUND for a missing file / empty image sequence, UNAVAILABLE for a device or stream that
  // cannot be opened, INVALID_ARGUMENT for an undecodable file or bad options.
  static absl::StatusOr<std::unique_ptr<CameraSource>> Open(
      const std::string& source, const CameraSourceOptions& options = {});

  // The next frame, resized and JPEG-encoded. OUT_OF_RANGE once the source has no more frames
  // (end of file or sequence, camera unplugged, stream closed); INTERNAL if encoding fails.
  absl::StatusOr<std::string> Next();
  // The same in two steps, for callers that look at a frame before sending it: the next frame
  // resized but not encoded, and a frame JPEG-encoded with the options' quality.
  absl::StatusOr<cv::Mat> NextImage();
  absl::StatusOr<std::string> Encode(const cv::Mat& frame) const;
  // Steps over the next frame without converting or encoding it (cv::VideoCapture::grab), e.g. to
  // sample a video. OUT_OF_RANGE at the end, as Next(). Counts in frames_read().
  absl::Status Skip();

  // What the source declares: frames per second and, for files, the number of frames; 0 when it
  // does not say (cameras, streams, some containers). A file's count may be an estimate.
  double fps() const;
  int64_t frame_count() const;

  SourceKind kind() const { return kind_; }
  const std::string& source() const { return source_; }
  int64_t frames_read() const { return frames_read_; }

 private:
  CameraSource(std::string source, SourceKind kind, const CameraSourceOptions& options);
  absl::Status EndError() const;  // OUT_OF_RANGE: no more frames

  std::string source_;
  SourceKind kind_;
  CameraSourceOptions options_;
  cv::VideoCapture capture_;
  int64_t frames_read_ = 0;
};

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_DEVICES_CAMERA_SOURCE_H_

#ifndef WAYMARK_SERVER_SERVICE_SLAM_VISUAL_FRAME_DECODER_H_
#define WAYMARK_SERVER_SERVICE_SLAM_VISUAL_FRAME_DECODER_H_

// Admission of one ImageFrame of a visual session: the JPEG/PNG image and the optional 16-bit PNG
// depth are decoded into the engine's FrameInput and checked against the session's camera, so a
// bad frame is answered at once with what is wrong and never reaches the engine. The image size
// is read from the file header before decoding: a frame of the wrong size is refused without
// allocating its pixels (no decompression bombs).

#include <cstddef>
#include <cstdint>

#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/visual_slam/types.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// Robot-supplied boxes per frame (a detector finds tens; this only bounds the work).
inline constexpr int kMaxFrameBoxes = 1000;

struct DecodedFrame {
  visual_slam::FrameInput input;
  bool want_features = false;
  double decode_ms = 0;
  size_t bytes = 0;  // pixel memory held by input
};

// INVALID_ARGUMENT "frame <sequence>: ..." when the stamp is not finite, the image is empty or not
// a JPEG/PNG OpenCV decodes, its size is not the camera's, the depth is not a 16-bit
// single-channel PNG of the same size, or a box is not finite or has a negative size (or there
// are more than kMaxFrameBoxes). Boxes are used (instead of the detector) when boxes_supplied is
// set or any box is sent.
absl::StatusOr<DecodedFrame> DecodeFrame(const v1::ImageFrame& frame, uint64_t sequence,
                                         const visual_slam::CameraModel& camera);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_VISUAL_FRAME_DECODER_H_

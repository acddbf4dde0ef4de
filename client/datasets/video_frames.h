#ifndef WAYMARK_CLIENT_DATASETS_VIDEO_FRAMES_H_
#define WAYMARK_CLIENT_DATASETS_VIDEO_FRAMES_H_

// Views of a crossing from a video driven through it (`waymark enroll NAME --video FILE`): frames
// sampled evenly in time, each tagged with its time as the capture position ("t=12.5s"), without
// the frames a server could do nothing with.
//
// Two cheap checks drop frames before they are sent, both on small grey copies (O(pixels), next to
// nothing beside decoding the video):
// - Blurry: the variance of the Laplacian at 320 pixels wide (the server's default working width,
//   the scale its SIFT features are found at) below `min_sharpness`. A motion-blurred or
//   out-of-focus frame has few strong edges, so SIFT finds few keypoints on it: the server rejects
//   it (under 10 keypoints) or stores a view that rarely matches. The default, 15, only drops
//   frames that are nearly flat (a sharp street scene measures in the hundreds); raise it for
//   videos with much motion blur.
// - Unchanged: the mean absolute grey difference to the last kept frame, at 64x48, below
//   `min_change` grey levels. A robot standing at the kerb (a red light, a pedestrian) films the
//   same view for seconds; storing it again and again adds nothing to recognition but clusters
//   and candidates. The default, 2 levels, is above sensor noise and JPEG wobble at that size and
//   far below what a 15 cm move changes.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::cli {

struct VideoSampling {
  double every_s = 0.5;    // one frame per this many seconds of video
  int max_frames = 200;    // at most this many frames kept (0 = no limit); see SampleVideo
  double min_sharpness = 15;  // variance of the Laplacian at 320 px wide; 0 keeps blurry frames
  double min_change = 2;      // mean absolute grey difference to the last kept frame; 0 keeps all
  int jpeg_quality = 90;      // the kept frames are sent as JPEG at the video's own size
};

struct SampledFrame {
  double t_s = 0;     // time in the video (frame index / frames per second)
  std::string jpeg;   // the frame, encoded
};

struct VideoSample {
  std::vector<SampledFrame> frames;  // kept, in time order
  double fps = 0;
  int64_t frames_read = 0;      // frames decoded or stepped over
  int64_t frames_declared = 0;  // what the file says it holds; 0 when it does not say
  double every_s = 0;           // the sampling step used (wider than asked for under max_frames)
  int sampled = 0;              // frames looked at: kept + blurry + unchanged
  int blurry = 0;
  int unchanged = 0;
  // The file ended well before the frame count it declares: truncated or corrupt after
  // frames_read frames. The frames sampled before that are kept.
  bool ended_early = false;

  int kept() const { return sampled - blurry - unchanged; }
  double duration_s() const { return fps > 0 ? static_cast<double>(frames_read) / fps : 0; }
};

// Called after each frame looked at, e.g. to redraw a progress bar over frames_declared.
using VideoProgress = std::function<void(const VideoSample&)>;

// Samples `file` from its first frame, one frame per `every_s` seconds. When the video is long
// enough to give more than max_frames, the step is widened to spread max_frames over the whole
// video (the frame count is known) or sampling stops at max_frames (it is not). NOT_FOUND for a
// missing file; INVALID_ARGUMENT for bad options, a file OpenCV cannot open or decode (no frame
// at all), or one that declares no frame rate; INTERNAL for an OpenCV failure mid-way (nothing
// sampled is returned then). A file that ends early is not an error: see `ended_early`.
absl::StatusOr<VideoSample> SampleVideo(const std::filesystem::path& file,
                                        const VideoSampling& options,
                                        const VideoProgress& progress = {});

// The capture position of a frame at `t_s` seconds: "t=12.5s", "t=0s", "t=3.25s" (at most 2
// decimals, trailing zeros dropped).
std::string FramePosition(double t_s);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_VIDEO_FRAMES_H_

#ifndef WAYMARK_CLIENT_SESSIONS_VO_SESSION_H_
#define WAYMARK_CLIENT_SESSIONS_VO_SESSION_H_

// `waymark vo run`: what the command line asks for (VoArgs), the visual session request it makes
// (camera, detector with its model files read here and uploaded as bytes, filter), and the run
// itself (vo_command.cc registers the command).

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "client/lib/slam_client.h"
#include "client/common/command_context.h"
#include "client/datasets/image_sequence.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

struct VoArgs {
  std::string sequence;     // a sequence folder or a bag
  std::string image_topic;  // bags: --image-topic (empty: the bag's only image topic)
  std::string detector = "none";  // none | hog | yolo:CFG,WEIGHTS | yolo:MODEL.onnx
  // Empty = the preset's (measured best: proven; --paper: full); else full | boxes | none | proven.
  std::string filter;
  // The paper's pipeline exactly (PRESET_PAPER) instead of the measured best (PRESET_MEASURED_BEST).
  bool paper = false;
  // Beyond the paper (unset = the preset's: docs/visual-odometry.md, "Defaults").
  std::optional<double> prior_direction_deg;  // monocular motion prior, degrees
  std::optional<int> bundle_window;           // local bundle adjustment, keyframes
  std::optional<int> relocalize;              // old keyframes kept to relocalise
  std::optional<double> static_hamming;       // eq 17's descriptor half, fraction of delta
  std::optional<int> proven_frames;           // filter proven: frames static before mapped
  std::string movable;            // comma-separated classes; empty = the server's default
  bool depth = false;
  std::string camera;  // preset name; empty = calib.txt or --fx ...
  std::optional<double> fx, fy, cx, cy;
  std::string distortion;  // "k1,k2,p1,p2[,k3]"
  std::optional<double> depth_scale;
  int max_frames = 0;   // 0 = all
  std::string out_dir;  // default ./out/vo-<sequence folder name>
  std::string robot_id = "vo";
  std::string name;
  int window = client::kDefaultFrameWindow;
  int sample_every = 25;  // feature pictures of every N-th frame (0 = none but the most dynamic)
  // A broken stream is reopened on the session until no frame has been answered for this long.
  double reconnect_seconds = 60;
};

// The camera for the session: the sequence's calib.txt, replaced by --camera, each value then
// replaced by its flag. INVALID_ARGUMENT naming the presets when nothing gives fx, fy, cx and cy.
absl::StatusOr<CameraIntrinsics> ResolveIntrinsics(const VoArgs& args,
                                                   const ImageSequence& sequence);

// --detector and --movable as a DetectorConfig; YOLO model files are read (NOT_FOUND naming a
// missing one), INVALID_ARGUMENT for an unknown form.
absl::StatusOr<v1::DetectorConfig> DetectorFromSpec(const std::string& spec,
                                                    const std::string& movable);

// full | boxes | none | proven; INVALID_ARGUMENT otherwise.
absl::StatusOr<v1::VisualSlamConfig::DynamicFilter> FilterFromName(const std::string& name);
// The reverse: "full", "boxes", "none", "proven".
std::string FilterName(v1::VisualSlamConfig::DynamicFilter filter);

// The whole CreateSessionRequest; width and height are the frames' size.
absl::StatusOr<v1::CreateSessionRequest> VoSessionRequest(const VoArgs& args,
                                                          const CameraIntrinsics& camera, int width,
                                                          int height);

int RunVo(CommandContext& context, const VoArgs& args);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_VO_SESSION_H_

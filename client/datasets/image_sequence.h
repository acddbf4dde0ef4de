#ifndef WAYMARK_CLIENT_DATASETS_IMAGE_SEQUENCE_H_
#define WAYMARK_CLIENT_DATASETS_IMAGE_SEQUENCE_H_

// Camera sequences on disk, for `waymark vo run` (issue 7). Two layouts:
// - TUM RGB-D (also the Bonn RGB-D Dynamic dataset): associations.txt (`t_rgb rgb/x.png t_depth
//   depth/x.png` per line) or rgb.txt (`t rgb/x.png`) with an optional depth.txt (`t depth/x.png`)
//   whose frames are paired with the colour frames by stamp like TUM's associate.py (0.02 s).
//   groundtruth.txt beside them is the ground truth. No intrinsics file: they come from the command
//   line or a camera preset (CameraPreset below).
// - KITTI odometry: image_0/*.png in name order, calib.txt (its first line, P0, gives fx fy cx cy;
//   with or without the `P0:` prefix), times.txt (one stamp per image) if present, else the
//   sensor's 10 Hz: image i at 0.1 * i s (kitti_stamps.h, the rule `eval ate` also gives poses.txt).
//   poses.txt beside them is the ground truth.
// - EuRoC MAV / ASL: mav0/cam0/data.csv + data/ + sensor.yaml (intrinsics and distortion), ground
//   truth mav0/state_groundtruth_estimate0/data.csv (euroc.h).
// Lists may carry '#' comments and blank lines; paths in them are relative to the sequence folder.
// Stamps must increase (the SLAM service rejects frames out of time order), and every listed file
// must exist: a sequence that would fail halfway through a run is refused before it starts.

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "client/datasets/stamped_pose3.h"

namespace waymark::cli {

// Pinhole camera with OpenCV's radial-tangential distortion, in pixels of the stored images.
struct CameraIntrinsics {
  double fx = 0;
  double fy = 0;
  double cx = 0;
  double cy = 0;
  std::array<double, 5> distortion{};  // k1, k2, p1, p2, k3; all zero = undistorted images
  double depth_scale = 0;              // depth image units per metre (TUM, Bonn: 5000); 0 = none
};

// "bonn", "tum1", "tum2", "tum3" and "kitti" (see image_sequence.cc for the sources).
// INVALID_ARGUMENT naming the presets for another name.
absl::StatusOr<CameraIntrinsics> CameraPreset(absl::string_view name);
// "bonn, tum1, tum2, tum3, kitti", for messages and help.
std::string CameraPresetNames();

// "k1,k2,p1,p2,k3" (4 values: k3 = 0); INVALID_ARGUMENT otherwise.
absl::StatusOr<std::array<double, 5>> ParseDistortion(absl::string_view text);

enum class SequenceLayout { kTum, kKitti, kEuroc };
const char* SequenceLayoutName(SequenceLayout layout);

struct SequenceFrame {
  double stamp = 0;                            // s
  std::filesystem::path image;                 // colour (TUM) or gray (KITTI) image
  std::optional<std::filesystem::path> depth;  // 16-bit depth image (TUM layouts only)
};

struct ImageSequence {
  std::filesystem::path dir;
  SequenceLayout layout = SequenceLayout::kTum;
  std::vector<SequenceFrame> frames;                 // in time order
  std::optional<CameraIntrinsics> intrinsics;        // from calib.txt (KITTI)
  std::optional<std::filesystem::path> groundtruth;  // groundtruth.txt (TUM) or poses.txt (KITTI)
  bool has_depth_list = false;                       // associations.txt or depth.txt was read
  int frames_without_depth = 0;  // colour frames with no depth frame within the pairing window
};

// Reads the sequence in `dir`: NOT_FOUND when `dir` holds neither layout or a listed file is
// missing; INVALID_ARGUMENT naming the file and line for a malformed list, stamps that do not
// increase, or a calib.txt without P0.
absl::StatusOr<ImageSequence> ReadImageSequence(const std::filesystem::path& dir);

// The sequence's ground truth with stamps comparable to its frames (KITTI poses get the frames'
// stamp rule). NOT_FOUND if it has none.
absl::StatusOr<std::vector<StampedPose3>> ReadSequenceGroundTruth(const ImageSequence& sequence);

// Largest stamp difference between a colour frame and its depth frame when pairing rgb.txt with
// depth.txt (TUM's associate.py default).
inline constexpr double kDepthPairingMaxDt = 0.02;

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_IMAGE_SEQUENCE_H_

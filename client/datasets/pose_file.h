#ifndef WAYMARK_CLIENT_DATASETS_POSE_FILE_H_
#define WAYMARK_CLIENT_DATASETS_POSE_FILE_H_

// Full 3-D trajectories from text files, for `waymark eval ate` (tum_trajectory.h is the planar
// reader/writer the laser tools use):
// - TUM RGB-D: `t tx ty tz qx qy qz qw` per line, '#' comments. Quaternions are normalised; a zero
//   one, or one whose norm is far from 1 (columns in the wrong order?), is refused.
// - KITTI odometry poses: 12 numbers per line, the 3x4 row-major [R|t]; no stamps: pose i gets
//   the i-th line of a KITTI times.txt, or else i * 0.1 s (KITTI's 10 Hz, kitti_stamps.h: the
//   stamps `vo run` gives the frames of a KITTI sequence). R must be a rotation (it is
//   re-orthonormalised).
// The format is detected from the column count of the first pose line, or forced.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "client/datasets/stamped_pose3.h"

namespace waymark::cli {

// kEuroc: EuRoC / ASL csv, `timestamp [ns], px, py, pz, qw, qx, qy, qz[, ...]` (euroc.h),
// detected by commas and 17 fields or a nanosecond stamp.
enum class PoseFormat { kAuto, kTum, kKitti, kEuroc };

// "auto", "tum", "kitti", "euroc"; INVALID_ARGUMENT otherwise.
absl::StatusOr<PoseFormat> ParsePoseFormat(absl::string_view name);
const char* PoseFormatName(PoseFormat format);

// The format of `text` by the column count of its first non-comment line (8: TUM, 12: KITTI).
// INVALID_ARGUMENT naming the line for another count, or for a text without poses.
absl::StatusOr<PoseFormat> DetectPoseFormat(const std::string& text);

struct PoseFileOptions {
  PoseFormat format = PoseFormat::kAuto;
  // KITTI stamps, one per pose; unset = 0, 0.1, 0.2, ... (DefaultKittiStamp). Not used for TUM.
  std::optional<std::vector<double>> kitti_stamps;
};

struct PoseFile {
  PoseFormat format = PoseFormat::kTum;  // the format read (never kAuto)
  std::vector<StampedPose3> poses;
};

// Parses text; INVALID_ARGUMENT naming the line for a malformed one.
absl::StatusOr<PoseFile> ParsePoseText(const std::string& text,
                                       const PoseFileOptions& options = {});
// The same for a file; errors are prefixed with the path.
absl::StatusOr<PoseFile> ReadPoseFile(const std::filesystem::path& path,
                                      const PoseFileOptions& options = {});

// KITTI times.txt: one stamp (s) per line.
absl::StatusOr<std::vector<double>> ParseStampList(const std::string& text);
absl::StatusOr<std::vector<double>> ReadStampListFile(const std::filesystem::path& path);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_POSE_FILE_H_

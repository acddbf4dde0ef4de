#ifndef WAYMARK_CLIENT_DATASETS_EUROC_H_
#define WAYMARK_CLIENT_DATASETS_EUROC_H_

// EuRoC MAV / ASL dataset folders (issue 35), for `waymark vo run` and `eval ate`:
//   mav0/cam0/data.csv     `#timestamp [ns],filename` then `1403636579763555584,1403636579763555584.png`
//   mav0/cam0/data/        the images
//   mav0/cam0/sensor.yaml  `intrinsics: [fu, fv, cu, cv]`, `distortion_model: radial-tangential`,
//                          `distortion_coefficients: [k1, k2, p1, p2]`, `resolution: [w, h]`,
//                          `T_BS: {data: [16 numbers]}` (the camera in the body frame, row-major)
//   mav0/state_groundtruth_estimate0/data.csv  `#timestamp, p_RS_R_x [m], p_RS_R_y, p_RS_R_z,
//                          q_RS_w, q_RS_x, q_RS_y, q_RS_z, ...` (17 columns; the body's pose)
// The folder given may be the one holding mav0/ or mav0/ itself. Stamps are nanoseconds; they
// become seconds. The sequence's ground truth is the camera's (body pose * T_BS); a bare
// data.csv read by `eval ate` is the body's (the lever arm is a few centimetres on EuRoC).

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/image_sequence.h"
#include "client/datasets/stamped_pose3.h"

namespace waymark::cli {

// The mav0 folder of `dir` (dir/mav0 or dir itself) when it holds cam0/data.csv; empty otherwise.
std::filesystem::path EurocRoot(const std::filesystem::path& dir);

struct EurocCamera {
  CameraIntrinsics intrinsics;
  int width = 0, height = 0;                         // resolution (0 when absent)
  Eigen::Matrix4d body_to_camera = Eigen::Matrix4d::Identity();  // T_BS
};

// sensor.yaml's camera; INVALID_ARGUMENT naming the key for a missing or malformed one, or a
// camera or distortion model other than pinhole / radial-tangential.
absl::StatusOr<EurocCamera> ParseEurocSensorYaml(const std::string& text);

// Fills frames (cam0/data.csv, in time order, every image checked to exist), intrinsics (sensor.yaml)
// and groundtruth (state_groundtruth_estimate0/data.csv when present) of a sequence whose dir is
// an EuRoC folder.
absl::Status ReadEurocSequence(ImageSequence* sequence);

// EuRoC ground truth (or any `timestamp_ns, px, py, pz, qw, qx, qy, qz[, ...]` csv):
// INVALID_ARGUMENT naming the line for fewer than 8 numbers or a quaternion far from unit norm.
absl::StatusOr<std::vector<StampedPose3>> ParseEurocPoses(const std::string& text);

// Whether a first data line looks like EuRoC's: comma-separated, at least 8 fields and a
// nanosecond stamp (over 1e15), or 17 fields.
bool LooksLikeEurocLine(const std::string& line);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_EUROC_H_

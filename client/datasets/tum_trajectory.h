#ifndef WAYMARK_CLIENT_DATASETS_TUM_TRAJECTORY_H_
#define WAYMARK_CLIENT_DATASETS_TUM_TRAJECTORY_H_

// Planar trajectories in the TUM RGB-D format: one pose per line, `t x y z qx qy qz qw`, `#`
// comments. Written with z = 0 and a rotation about z only; read back with the yaw of the
// quaternion (z and roll/pitch are ignored).

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::cli {

struct Pose2 {
  double x = 0;
  double y = 0;
  double theta = 0;
};

struct StampedPose {
  double stamp = 0;  // s
  Pose2 pose;
};

// One line per pose, stamps with microsecond precision (Unix stamps need 16 digits).
void WriteTum(std::ostream& out, const std::vector<StampedPose>& poses);
absl::Status WriteTumFile(const std::filesystem::path& path, const std::vector<StampedPose>& poses);

// Parses TUM text; INVALID_ARGUMENT naming the line for a malformed one.
absl::StatusOr<std::vector<StampedPose>> ParseTum(const std::string& text);
absl::StatusOr<std::vector<StampedPose>> ReadTumFile(const std::filesystem::path& path);

// Yaw of the unit quaternion (qx, qy, qz, qw) about z (atan2 form; tolerant of non-unit input).
double YawFromQuaternion(double qx, double qy, double qz, double qw);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_TUM_TRAJECTORY_H_

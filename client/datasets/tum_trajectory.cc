#include "client/datasets/tum_trajectory.h"
#include "client/common/numeric_table.h"

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/common/read_file.h"

namespace waymark::cli {

double YawFromQuaternion(double qx, double qy, double qz, double qw) {
  return std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz));
}

void WriteTum(std::ostream& out, const std::vector<StampedPose>& poses) {
  out << "# t x y z qx qy qz qw\n";
  for (const StampedPose& p : poses) {
    const double half = 0.5 * p.pose.theta;
    out << fmt::format("{:.6f} {:.6f} {:.6f} 0 0 0 {:.9f} {:.9f}\n", p.stamp, p.pose.x, p.pose.y,
                       std::sin(half), std::cos(half));
  }
}

absl::Status WriteTumFile(const std::filesystem::path& path,
                          const std::vector<StampedPose>& poses) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
  WriteTum(out, poses);
  out.close();
  if (!out) return absl::DataLossError("writing '" + path.string() + "' failed");
  return absl::OkStatus();
}

absl::StatusOr<std::vector<StampedPose>> ParseTum(const std::string& text) {
  absl::StatusOr<std::vector<NumericRow>> rows =
      ParseNumericRows(text, 8, "t x y z qx qy qz qw", " \t,");
  if (!rows.ok()) return rows.status();
  std::vector<StampedPose> poses;
  poses.reserve(rows->size());
  for (const NumericRow& row : *rows) {
    const std::vector<double>& v = row.values;
    if (v[4] == 0 && v[5] == 0 && v[6] == 0 && v[7] == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("line ", row.line, ": the quaternion is zero"));
    }
    poses.push_back({v[0], {v[1], v[2], YawFromQuaternion(v[4], v[5], v[6], v[7])}});
  }
  return poses;
}

absl::StatusOr<std::vector<StampedPose>> ReadTumFile(const std::filesystem::path& path) {
  return ReadAndParse(path, ParseTum);
}

}  // namespace waymark::cli

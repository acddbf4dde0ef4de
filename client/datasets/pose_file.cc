#include "client/datasets/pose_file.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/common/numeric_table.h"
#include "client/datasets/euroc.h"
#include "client/datasets/kitti_stamps.h"

namespace waymark::cli {
namespace {

constexpr absl::string_view kSeparators = " \t,";
constexpr absl::string_view kTumLayout = "t tx ty tz qx qy qz qw";
constexpr absl::string_view kKittiLayout = "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz";
// Largest accepted |norm - 1| of a TUM quaternion before normalising.
constexpr double kQuaternionNormTolerance = 0.1;
// Largest accepted max |R^T R - I| of a KITTI rotation before re-orthonormalising.
constexpr double kRotationTolerance = 1e-2;

absl::StatusOr<std::vector<StampedPose3>> ParseTumPoses(const std::string& text) {
  absl::StatusOr<std::vector<NumericRow>> rows = ParseNumericRows(text, 8, kTumLayout, kSeparators);
  if (!rows.ok()) return rows.status();
  std::vector<StampedPose3> poses;
  poses.reserve(rows->size());
  for (const NumericRow& row : *rows) {
    const std::vector<double>& v = row.values;
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // (w, x, y, z)
    const double norm = q.norm();
    if (norm < 1e-9) {
      return absl::InvalidArgumentError(
          absl::StrCat("line ", row.line, ": the quaternion (qx qy qz qw) is zero"));
    }
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
      return absl::InvalidArgumentError(
          absl::StrCat("line ", row.line, ": the quaternion (qx qy qz qw) has norm ", norm,
                       ", far from 1 (expected columns ", kTumLayout, ")"));
    }
    q.normalize();
    StampedPose3 pose;
    pose.stamp = v[0];
    pose.translation = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.rotation = q.toRotationMatrix();
    poses.push_back(pose);
  }
  return poses;
}

absl::StatusOr<std::vector<StampedPose3>> ParseKittiPoses(
    const std::string& text, const std::optional<std::vector<double>>& stamps) {
  absl::StatusOr<std::vector<NumericRow>> rows =
      ParseNumericRows(text, 12, kKittiLayout, kSeparators);
  if (!rows.ok()) return rows.status();
  if (stamps.has_value() && stamps->size() != rows->size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        rows->size(), " KITTI poses but ", stamps->size(), " time stamps: the counts must agree"));
  }
  std::vector<StampedPose3> poses;
  poses.reserve(rows->size());
  for (size_t i = 0; i < rows->size(); ++i) {
    const NumericRow& row = (*rows)[i];
    const std::vector<double>& v = row.values;
    Eigen::Matrix3d r;
    r << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    const double off = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (off > kRotationTolerance || r.determinant() <= 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("line ", row.line, ": the 3x3 block is not a rotation (|R^T R - I| = ", off,
                       ", det = ", r.determinant(), "; expected 12 numbers ", kKittiLayout, ")"));
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
    StampedPose3 pose;
    pose.stamp = stamps.has_value() ? (*stamps)[i] : DefaultKittiStamp(i);
    pose.rotation = svd.matrixU() * svd.matrixV().transpose();
    pose.translation = Eigen::Vector3d(v[3], v[7], v[11]);
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace

absl::StatusOr<PoseFormat> ParsePoseFormat(absl::string_view name) {
  if (name == "auto") return PoseFormat::kAuto;
  if (name == "tum") return PoseFormat::kTum;
  if (name == "kitti") return PoseFormat::kKitti;
  if (name == "euroc") return PoseFormat::kEuroc;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown pose format '", name, "' (auto, tum, kitti or euroc)"));
}

const char* PoseFormatName(PoseFormat format) {
  switch (format) {
    case PoseFormat::kAuto:
      return "auto";
    case PoseFormat::kTum:
      return "tum";
    case PoseFormat::kKitti:
      return "kitti";
    case PoseFormat::kEuroc:
      return "euroc";
  }
  return "?";
}

absl::StatusOr<PoseFormat> DetectPoseFormat(const std::string& text) {
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line[0] == '#') continue;
    if (LooksLikeEurocLine(std::string(line))) return PoseFormat::kEuroc;
    const std::vector<absl::string_view> fields =
        absl::StrSplit(line, absl::ByAnyChar(kSeparators), absl::SkipEmpty());
    if (fields.size() == 8) return PoseFormat::kTum;
    if (fields.size() == 12) return PoseFormat::kKitti;
    return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ": ", fields.size(),
                                                   " fields; expected 8 (TUM: ", kTumLayout,
                                                   ") or 12 (KITTI: 3x4 row-major [R|t])"));
  }
  return absl::InvalidArgumentError("no poses (only blank lines and '#' comments)");
}

absl::StatusOr<PoseFile> ParsePoseText(const std::string& text, const PoseFileOptions& options) {
  PoseFile file;
  file.format = options.format;
  if (file.format == PoseFormat::kAuto) {
    absl::StatusOr<PoseFormat> detected = DetectPoseFormat(text);
    if (!detected.ok()) return detected.status();
    file.format = *detected;
  }
  absl::StatusOr<std::vector<StampedPose3>> poses =
      file.format == PoseFormat::kEuroc ? ParseEurocPoses(text)
      : file.format == PoseFormat::kTum ? ParseTumPoses(text)
                                        : ParseKittiPoses(text, options.kitti_stamps);
  if (!poses.ok()) return poses.status();
  file.poses = *std::move(poses);
  return file;
}

absl::StatusOr<PoseFile> ReadPoseFile(const std::filesystem::path& path,
                                      const PoseFileOptions& options) {
  return ReadAndParse(path, [&](const std::string& text) { return ParsePoseText(text, options); });
}

absl::StatusOr<std::vector<double>> ParseStampList(const std::string& text) {
  absl::StatusOr<std::vector<NumericRow>> rows = ParseNumericRows(text, 1, "t", kSeparators);
  if (!rows.ok()) return rows.status();
  std::vector<double> stamps;
  stamps.reserve(rows->size());
  for (const NumericRow& row : *rows) stamps.push_back(row.values[0]);
  return stamps;
}

absl::StatusOr<std::vector<double>> ReadStampListFile(const std::filesystem::path& path) {
  return ReadAndParse(path, ParseStampList);
}

}  // namespace waymark::cli

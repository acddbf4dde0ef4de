#include "server/laser_slam/odometry_buffer.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/input_bounds.h"

namespace waymark::laser_slam {

absl::Status OdometryBuffer::Add(const OdometryReading& reading) {
  if (!std::isfinite(reading.stamp) || !std::isfinite(reading.pose.x) ||
      !std::isfinite(reading.pose.y) || !std::isfinite(reading.pose.theta)) {
    return absl::InvalidArgumentError("odometry stamp and pose must be finite");
  }
  if (!PlausibleStamp(reading.stamp)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "odometry stamp ", reading.stamp, " s is not a time (|stamp| <= ", kMaxAbsStampS, ")"));
  }
  if (std::abs(reading.pose.x) > kMaxAbsOdometryM || std::abs(reading.pose.y) > kMaxAbsOdometryM ||
      std::abs(reading.pose.theta) > kMaxAbsOdometryRad) {
    return absl::InvalidArgumentError(
        absl::StrCat("odometry pose (", reading.pose.x, ", ", reading.pose.y, ", ",
                     reading.pose.theta, ") is out of range: |x|, |y| <= ", kMaxAbsOdometryM,
                     " m, |theta| <= ", kMaxAbsOdometryRad, " rad"));
  }
  if (!readings_.empty() && reading.stamp <= readings_.back().stamp) {
    return absl::InvalidArgumentError(
        absl::StrCat("odometry stamp ", reading.stamp, " is not after the previous one (",
                     readings_.back().stamp, "): odometry must arrive in time order"));
  }
  readings_.push_back(reading);
  if (static_cast<int>(readings_.size()) > kCapacity) readings_.pop_front();
  return absl::OkStatus();
}

std::optional<Pose2> OdometryBuffer::At(double stamp) const {
  if (readings_.empty()) return std::nullopt;
  if (stamp <= readings_.front().stamp) return readings_.front().pose;
  if (stamp >= readings_.back().stamp) return readings_.back().pose;
  auto after = std::lower_bound(readings_.begin(), readings_.end(), stamp,
                                [](const OdometryReading& r, double t) { return r.stamp < t; });
  auto before = after - 1;
  const double w = (stamp - before->stamp) / (after->stamp - before->stamp);
  const Pose2& a = before->pose;
  const Pose2& b = after->pose;
  return Pose2{a.x + w * (b.x - a.x), a.y + w * (b.y - a.y),
               NormalizeAngle(a.theta + w * NormalizeAngle(b.theta - a.theta))};
}

void OdometryBuffer::DropBefore(double stamp) {
  // Keep the last reading at or before `stamp`: it brackets the next lookup.
  while (readings_.size() >= 2 && readings_[1].stamp <= stamp) readings_.pop_front();
}

std::optional<double> OdometryBuffer::last_stamp() const {
  if (readings_.empty()) return std::nullopt;
  return readings_.back().stamp;
}

}  // namespace waymark::laser_slam

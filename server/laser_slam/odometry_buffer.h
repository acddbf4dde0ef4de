#ifndef WAYMARK_SERVER_LASER_SLAM_ODOMETRY_BUFFER_H_
#define WAYMARK_SERVER_LASER_SLAM_ODOMETRY_BUFFER_H_

// Recent wheel-odometry readings, to look the odometry pose up at a scan's stamp. Bounded: a robot
// that sends odometry and never a scan cannot grow it.

#include <deque>
#include <optional>

#include "absl/status/status.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

class OdometryBuffer {
 public:
  static constexpr int kCapacity = 512;

  // Stamps must strictly increase.
  absl::Status Add(const OdometryReading& reading);
  // The odometry pose at `stamp`: interpolated between the readings around it, the nearest
  // reading when the stamp lies outside them, nothing when there has never been a reading.
  std::optional<Pose2> At(double stamp) const;
  // Readings older than `stamp` that are no longer needed for interpolation are dropped.
  void DropBefore(double stamp);
  std::optional<double> last_stamp() const;
  const std::deque<OdometryReading>& readings() const { return readings_; }

 private:
  std::deque<OdometryReading> readings_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_ODOMETRY_BUFFER_H_

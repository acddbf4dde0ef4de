#ifndef WAYMARK_CLIENT_SESSIONS_CARMEN_LASER_SOURCE_H_
#define WAYMARK_CLIENT_SESSIONS_CARMEN_LASER_SOURCE_H_

// A CARMEN log as a LaserSource (laser_source.h): the laser lines of a CarmenLaserFeed (stamp
// order, or restamped), each with the odometry pose its own line carries (FLASER odom_x/y/theta,
// ROBOTLASER1 robot_x/y/theta); the laser's mounting from the first line (LaserMount in
// slam_replay.h). A log that pairs its scans with the odometry of other scans is put right
// (client/datasets/odometry_lag.h), and Warnings() says so.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "client/datasets/carmen_laser_feed.h"
#include "client/datasets/laser_source.h"
#include "client/datasets/odometry_lag.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {

// The sample a laser line gives.
adapters::LaserSample SampleOf(const adapters::CarmenLaser& laser);

class CarmenLaserSource : public adapters::LaserSource {
 public:
  // Opens `log` (plain, .gz or .bz2), restamped at `restamp_rate_hz` when > 0, each scan with
  // the odometry the log gives the scan odometry_lag lines later; nullopt: the lag estimated from
  // the log first (EstimateOdometryLag: one more pass over it).
  static absl::StatusOr<std::unique_ptr<CarmenLaserSource>> Open(
      const std::string& log, double restamp_rate_hz = 0, std::optional<int> odometry_lag = 0);
  explicit CarmenLaserSource(std::unique_ptr<adapters::CarmenLaserFeed> feed,
                             adapters::OdometryLag lag = {});

  absl::StatusOr<bool> Next(adapters::LaserSample* sample) override;
  Pose2 LaserMount() const override { return mount_; }
  adapters::LaserSourceCounts counts() const override;
  std::vector<std::string> Warnings() const override;
  std::string BrokenStampsWarning() const override;

  adapters::CarmenLaserFeed& feed() { return *feed_; }

 private:
  std::unique_ptr<adapters::CarmenLaserFeed> feed_;
  adapters::OdometryLag lag_;  // as estimated (all zero when given)
  bool first_ = true;
  Pose2 mount_;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_CARMEN_LASER_SOURCE_H_

#ifndef WAYMARK_CLIENT_DATASETS_LASER_SOURCE_H_
#define WAYMARK_CLIENT_DATASETS_LASER_SOURCE_H_

// What `waymark slam replay` (and `slam odometry`) read a recording through: scans in increasing
// stamp order, each with the robot's odometry pose at its stamp, and where the laser sits on the
// robot. A CARMEN log (carmen_laser_source.h) and a ROS bag (client/ros/bag_laser_feed.h) are the
// two implementations, so the replay loop is written once.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/tum_trajectory.h"  // Pose2

namespace waymark::adapters {

struct LaserSample {
  double stamp = 0;            // s; above every stamp returned before
  cli::Pose2 odom;             // the robot's odometry pose at `stamp` (m, m, rad)
  double angle_min = 0;        // bearing of the first beam in the laser frame (rad)
  double angle_increment = 0;  // rad
  double no_return_range = 0;  // readings at or above are no-returns; 0 = unknown
  std::vector<float> ranges;   // m, one per beam; NaN = no reading
};

// What a source read and skipped, for the replay's report (the CARMEN names: a bag's "laser
// lines" are its scan messages, its "odometry lines" the odometry or TF messages used).
struct LaserSourceCounts {
  int64_t laser_lines = 0;      // scans read so far
  int64_t skipped_stamps = 0;   // scans skipped because their stamp did not increase
  int64_t reordered_lines = 0;  // scans read after one with a later stamp (then put in order)
  int64_t malformed_lines = 0;  // records that could not be read, skipped
  int64_t odometry_lines = 0;   // odometry records read
  bool stamps_broken = false;   // most scans were skipped for their stamps
  // Each scan was sent with the odometry its log gives the scan this many lines later
  // (odometry_lag.h; CARMEN logs).
  int odometry_lag_scans = 0;
};

class LaserSource {
 public:
  virtual ~LaserSource() = default;

  // The next scan; false at the end. An error ends the replay (an unreadable file).
  virtual absl::StatusOr<bool> Next(LaserSample* sample) = 0;

  // The laser's pose on the robot (x forward, y left, theta), known once the first sample is
  // read.
  virtual cli::Pose2 LaserMount() const = 0;

  virtual LaserSourceCounts counts() const = 0;

  // Problems that did not stop reading, one line each, for stderr (printed after the replay).
  virtual std::vector<std::string> Warnings() const = 0;

  // The loud warning (WARNING lines, newline-terminated) when the stamps made most scans unusable;
  // empty otherwise. A replay with it exits 1.
  virtual std::string BrokenStampsWarning() const = 0;

  // Facts about the source for summary.json beyond the counts ("format", "scan_topic", ...);
  // empty for a CARMEN log.
  virtual std::vector<std::pair<std::string, std::string>> Facts() const { return {}; }
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DATASETS_LASER_SOURCE_H_

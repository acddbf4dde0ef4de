#include "server/laser_slam/laser_slam.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/line_extraction.h"

namespace waymark::laser_slam {

// TEMPORARY dead-reckoning body so that the service and client can be built against the API while
// the EKF is written (issue 3 in progress).
struct LaserSlam::Impl {
  SlamOptions options;
  std::vector<OdometryReading> odometry;  // last two readings
  bool have_scan = false;
  double last_scan_stamp = 0.0;
  Pose2 last_scan_odom;
  Pose2 pose;
  std::vector<PoseEstimate> trajectory;
  std::uint64_t revision = 0;
  std::uint64_t scans = 0;
};

LaserSlam::LaserSlam(const SlamOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
}
LaserSlam::~LaserSlam() = default;

absl::Status LaserSlam::AddOdometry(const OdometryReading& reading) {
  if (!impl_->odometry.empty() && reading.stamp <= impl_->odometry.back().stamp) {
    return absl::InvalidArgumentError(absl::StrCat("odometry stamp ", reading.stamp,
                                                   " is not after the previous one ",
                                                   impl_->odometry.back().stamp));
  }
  impl_->odometry.push_back(reading);
  if (impl_->odometry.size() > 2) impl_->odometry.erase(impl_->odometry.begin());
  return absl::OkStatus();
}

absl::StatusOr<ScanUpdate> LaserSlam::AddScan(const LaserScan& scan) {
  if (impl_->have_scan && scan.stamp <= impl_->last_scan_stamp) {
    return absl::InvalidArgumentError("scan stamp not increasing");
  }
  absl::StatusOr<std::vector<ObservedSegment>> segments =
      ExtractSegments(scan, impl_->options.extraction);
  if (!segments.ok()) return segments.status();
  Pose2 odom = impl_->odometry.empty() ? Pose2{} : impl_->odometry.back().pose;
  if (impl_->have_scan) {
    impl_->pose = Compose(impl_->pose, Relative(impl_->last_scan_odom, odom));
  }
  impl_->last_scan_odom = odom;
  impl_->have_scan = true;
  impl_->last_scan_stamp = scan.stamp;
  ++impl_->scans;
  ScanUpdate update;
  update.pose.stamp = scan.stamp;
  update.pose.pose = impl_->pose;
  update.observed = static_cast<int>(segments->size());
  impl_->trajectory.push_back(update.pose);
  return update;
}

PoseEstimate LaserSlam::CurrentPose() const {
  return impl_->trajectory.empty() ? PoseEstimate{} : impl_->trajectory.back();
}
std::vector<MapSegment> LaserSlam::Map() const { return {}; }
const std::vector<PoseEstimate>& LaserSlam::Trajectory() const { return impl_->trajectory; }
std::uint64_t LaserSlam::map_revision() const { return impl_->revision; }
std::uint64_t LaserSlam::scans_processed() const { return impl_->scans; }
const SlamOptions& LaserSlam::options() const { return impl_->options; }

std::string LaserSlam::SerializeState() const { return "WMLS0"; }

absl::StatusOr<std::unique_ptr<LaserSlam>> LaserSlam::FromCheckpoint(
    const SlamOptions& options, absl::string_view state, std::vector<PoseEstimate> trajectory) {
  if (state != "WMLS0") return absl::DataLossError("bad laser SLAM checkpoint");
  auto slam = std::make_unique<LaserSlam>(options);
  slam->impl_->trajectory = std::move(trajectory);
  return slam;
}

}  // namespace waymark::laser_slam

#include "client/sessions/carmen_laser_source.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <utility>

#include "client/sessions/slam_replay.h"  // LaserMount

namespace waymark::cli {

using adapters::CarmenLaser;
using adapters::CarmenLaserFeed;
using adapters::CarmenLogReader;
using adapters::CarmenRecord;
using adapters::LaserFeedOptions;
using adapters::LaserSample;
using adapters::LaserSourceCounts;
using adapters::OdometryLag;

LaserSample SampleOf(const CarmenLaser& laser) {
  LaserSample sample;
  sample.stamp = laser.stamp;
  sample.odom = {laser.odom_pose.x, laser.odom_pose.y, laser.odom_pose.theta};
  sample.angle_min = laser.angle_min;
  sample.angle_increment = laser.angle_increment;
  sample.no_return_range = laser.no_return_range;
  sample.ranges = laser.ranges;
  return sample;
}

absl::StatusOr<std::unique_ptr<CarmenLaserSource>> CarmenLaserSource::Open(
    const std::string& log, double restamp_rate_hz, std::optional<int> odometry_lag) {
  auto reader = CarmenLogReader::Open(log);
  if (!reader.ok()) return reader.status();
  OdometryLag lag;
  if (!odometry_lag) {
    // A log that cannot be read whole keeps its pairing: the replay reports what is wrong.
    absl::StatusOr<OdometryLag> estimated = adapters::EstimateOdometryLagOfLog(log);
    if (estimated.ok()) lag = *estimated;
  }
  LaserFeedOptions options;
  options.restamp_rate_hz = restamp_rate_hz;
  options.odometry_lag_scans = odometry_lag ? *odometry_lag : lag.lag_scans;
  return std::make_unique<CarmenLaserSource>(
      std::make_unique<CarmenLaserFeed>(*std::move(reader), options), lag);
}

CarmenLaserSource::CarmenLaserSource(std::unique_ptr<CarmenLaserFeed> feed, OdometryLag lag)
    : feed_(std::move(feed)), lag_(lag) {}

absl::StatusOr<bool> CarmenLaserSource::Next(LaserSample* sample) {
  CarmenRecord record;
  absl::StatusOr<bool> more = feed_->Next(&record);
  if (!more.ok() || !*more) return more;
  if (first_) mount_ = ::waymark::cli::LaserMount(record.laser);
  first_ = false;
  *sample = SampleOf(record.laser);
  return true;
}

LaserSourceCounts CarmenLaserSource::counts() const {
  LaserSourceCounts counts;
  counts.laser_lines = feed_->laser_lines();
  counts.skipped_stamps = feed_->skipped_stamps();
  counts.reordered_lines = feed_->reordered_lines();
  counts.malformed_lines = feed_->reader().malformed_lines();
  counts.odometry_lines = feed_->odometry_lines();
  counts.stamps_broken = feed_->StampsBroken();
  counts.odometry_lag_scans = feed_->odometry_lag_scans();
  return counts;
}

std::vector<std::string> CarmenLaserSource::Warnings() const {
  std::vector<std::string> warnings;
  if (lag_.decided()) {
    warnings.push_back(adapters::DescribeOdometryLag(lag_) +
                       ": moved back (--odometry-lag 0 keeps the log's pairing)");
  }
  const CarmenLogReader& reader = feed_->reader();
  if (reader.malformed_lines() == 0) return warnings;
  std::string text = fmt::format("skipped {} malformed line(s)", reader.malformed_lines());
  for (const std::string& error : reader.first_errors()) text += "\n  " + error;
  warnings.push_back(text);
  return warnings;
}

std::string CarmenLaserSource::BrokenStampsWarning() const {
  const CarmenLaserFeed& feed = *feed_;
  if (!feed.StampsBroken()) return "";
  const int64_t skipped = feed.skipped_stamps();
  const int64_t earlier = skipped - feed.repeated_stamps();
  std::vector<std::string> why;
  if (feed.repeated_stamps() > 0) {
    why.push_back(fmt::format("{} repeat the stamp {:.10g} of a line before them",
                              feed.repeated_stamps(), feed.last_repeated_stamp()));
  }
  if (earlier > 0) {
    why.push_back(fmt::format("{} are earlier than a line more than {} laser lines before them",
                              earlier, CarmenLaserFeed::kReorderWindow));
  }
  return fmt::format(
      "WARNING: {} of {} laser lines ({:.1f}%) were skipped because their stamps do not increase "
      "({}): this log's stamps are broken, and only {} scans were used.\n"
      "WARNING: run it again with --restamp to stamp the scans from their order in the log (at "
      "{:g} Hz, or --rate HZ).\n",
      skipped, feed.laser_lines(), 100.0 * static_cast<double>(skipped) / feed.laser_lines(),
      fmt::join(why, "; "), feed.laser_lines() - skipped, adapters::kDefaultRestampRateHz);
}

}  // namespace waymark::cli

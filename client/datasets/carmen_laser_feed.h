#ifndef WAYMARK_CLIENT_DATASETS_CARMEN_LASER_FEED_H_
#define WAYMARK_CLIENT_DATASETS_CARMEN_LASER_FEED_H_

// The laser lines of a CARMEN log in the order a SLAM session takes them: strictly increasing
// stamps. Two ways to get there:
//
// The log's own stamps (the default). Lines are reordered within a lookahead of kReorderWindow
// laser lines (the Intel log has 631 FLASER lines with a smaller stamp than the line before them,
// none repeated, none more than 14 lines out of place; reordered_lines() counts the lines whose
// stamp is below one read earlier: 1612 there). A line whose stamp still does not increase (a
// repeat, or earlier than the lookahead can fix) is skipped and counted, since a session would
// reject it. Some published logs have no usable stamps at all: in Radish's corrected
// infinite-corridor log 1937 of 1941 FLASER lines carry 4294967295 (-1 as an unsigned 32-bit
// number), in orebro and freiburg-campus every stamp is 0, in belgioioso every stamp is the same.
// Those logs keep a handful of scans; StampsBroken() says so.
//
// Restamped (restamp_rate_hz > 0): the log's stamps are ignored and the i-th laser line (from 0)
// gets the stamp i / restamp_rate_hz, in file order; nothing is reordered or skipped.
//
// ODOM lines are read and counted but not returned: every laser line carries the odometry pose at
// its own instant, or, with odometry_lag_scans = k, the one the log gives the laser line k lines
// later in the file (clamped at the log's ends; its logged laser pose moves with it): the fix for
// a log that pairs scans with another scan's odometry (client/datasets/odometry_lag.h).

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/carmen_log.h"

namespace waymark::adapters {

// The laser rate --restamp assumes unless told: the raw CARMEN logs here scan at about 5 Hz
// (aces 5.4, intel 5.1, mit-csail 4.7 Hz). Corrected logs keep fewer scans (one every 1-5 s), so
// at 5 Hz they replay faster than they were recorded; only pacing and durations depend on it.
inline constexpr double kDefaultRestampRateHz = 5.0;

struct LaserFeedOptions {
  double restamp_rate_hz = 0;  // > 0: stamps from the line order (see the file comment)
  int odometry_lag_scans = 0;  // see the file comment
};

class CarmenLaserFeed {
 public:
  static constexpr size_t kReorderWindow = 64;

  explicit CarmenLaserFeed(std::unique_ptr<CarmenLogReader> reader, LaserFeedOptions options = {});

  // The next laser record, its stamp above every one returned before; false at the end of the log.
  absl::StatusOr<bool> Next(CarmenRecord* record);

  CarmenLogReader& reader() { return *reader_; }
  bool restamped() const { return options_.restamp_rate_hz > 0; }
  int odometry_lag_scans() const { return options_.odometry_lag_scans; }
  double restamp_rate_hz() const { return options_.restamp_rate_hz; }

  int64_t laser_lines() const { return laser_lines_; }  // read from the log so far
  int64_t odometry_lines() const { return odometry_lines_; }
  int64_t reordered_lines() const { return reordered_; }
  // Skipped for their stamp, of which repeated_stamps() repeat the stamp returned last (the rest
  // are earlier than it).
  int64_t skipped_stamps() const { return skipped_repeated_ + skipped_earlier_; }
  int64_t repeated_stamps() const { return skipped_repeated_; }
  // The stamp repeated most recently (meaningful when repeated_stamps() > 0).
  double last_repeated_stamp() const { return last_repeated_stamp_; }
  // Most laser lines read so far were skipped for their stamps: the log's stamps are not usable
  // and a replay kept only a few scans. Never true when restamped.
  bool StampsBroken() const { return 2 * skipped_stamps() > laser_lines_; }

 private:
  absl::StatusOr<bool> NextRestamped(CarmenRecord* record);
  // The next laser line in file order, its odometry moved by odometry_lag_scans; counts the lines.
  absl::StatusOr<bool> NextLaserLine(CarmenRecord* record);
  static bool Later(const CarmenRecord& a, const CarmenRecord& b);

  std::unique_ptr<CarmenLogReader> reader_;
  const LaserFeedOptions options_;
  std::vector<CarmenRecord> pending_;  // min-heap by stamp (then line)
  bool eof_ = false;
  bool have_read_ = false;
  double max_read_ = 0;
  bool have_last_ = false;
  double last_stamp_ = 0;
  int64_t laser_lines_ = 0;
  int64_t odometry_lines_ = 0;
  int64_t reordered_ = 0;
  int64_t skipped_repeated_ = 0;
  int64_t skipped_earlier_ = 0;
  double last_repeated_stamp_ = 0;
  // odometry_lag_scans < 0: the last -lag + 1 laser lines read (for their poses); > 0: the
  // lines read ahead, waiting for the poses lag lines later.
  std::deque<CarmenRecord> lag_window_;
  bool lines_done_ = false;
  int64_t restamped_lines_ = 0;  // returned so far when restamped
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DATASETS_CARMEN_LASER_FEED_H_

#ifndef WAYMARK_CLIENT_DATASETS_ODOMETRY_LAG_H_
#define WAYMARK_CLIENT_DATASETS_ODOMETRY_LAG_H_

// Whether a laser log pairs each scan with the odometry of another scan, and with which.
//
// A CARMEN laser line carries the odometry pose "at its own instant"; a log converted from
// another format can pair each scan with the odometry of a scan before or after it (MIT Killian
// as MOLA's rawlog gives it back: one scan ahead; docs/results.md, issue 33's tenth part). SLAM
// then takes the odometry's turn a scan early: wherever the robot turns, the prior is off by a
// whole scan's rotation.
//
// The estimate needs no reference and no scan matcher. For each pair of consecutive scans the
// laser's own turn is read from the directions of the walls it sees (a histogram of the
// directions between neighbouring points, in half degrees: a robot turning by d sees every wall
// turn by -d, and moving does not turn them), as the shift that best overlays the two
// histograms. On the pairs where the laser clearly turned (two beam increments or more), a lag
// of k scans is nearer than lag j where the odometry's turn between scans i + k and i + 1 + k is
// nearer the laser's. Starting from 0, the lag steps one whole scan at a time towards the side
// that is nearer, as long as the next lag is nearer than the current one on so many more pairs
// than the reverse that a fair coin would do as well once in 10^6 tries (a sign test): a log
// whose odometry is in step keeps it as it is, and a lag that is not clearly a whole scan (a
// driver's latency of part of one) is left alone.

#include <array>
#include <deque>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/carmen_log.h"

namespace waymark::adapters {

struct OdometryLag {
  int lag_scans = 0;         // scan i's odometry is the one the log gives scan i + lag_scans
  int turning_pairs = 0;     // consecutive scans whose laser turned by two increments or more
  // The first step from lag 0 (the nearer side, whether taken or not): the pairs nearer that
  // lag's odometry, those nearer lag 0's (the rest tie), and the sign test's chance (log10).
  int for_lag = 0;
  int for_in_step = 0;
  double log10_chance = 0;
  bool decided() const { return lag_scans != 0; }
};

inline constexpr int kMaxOdometryLagScans = 2;
inline constexpr double kOdometryLagLog10Chance = -6.0;

// The laser's turn from `a` to `b` (rad, counter-clockwise positive, at most max_shift_rad
// either way), from the directions of the walls both see; 0 when either sees no wall.
double ScanRotation(const CarmenLaser& a, const CarmenLaser& b, double max_shift_rad);

// The estimate over lasers added in log order (odom_pose as logged), holding a few lasers and
// five numbers per turning pair, so that a long log is read once in bounded memory.
class OdometryLagEstimator {
 public:
  void Add(const CarmenLaser& laser);
  OdometryLag Result() const;

 private:
  static constexpr int kLags = 2 * kMaxOdometryLagScans + 1;  // index l: lag l - kMax...
  static constexpr size_t kWindow = 2 * kMaxOdometryLagScans + 2;
  using Misses = std::array<double, kLags>;  // per lag: its odometry's turn off the laser's
  std::deque<CarmenLaser> window_;
  // The wall-direction histograms of the current pair's two scans (empty: not made yet), so
  // that each scan's is made once.
  std::vector<double> first_histogram_, second_histogram_;
  std::vector<Misses> misses_;
};

// The same over a vector of lasers in log order.
OdometryLag EstimateOdometryLag(const std::vector<CarmenLaser>& lasers);
// Over the laser lines of the log at `path` (plain, .gz or .bz2), read in file order; the
// reader's error when it cannot be opened or a line is broken.
absl::StatusOr<OdometryLag> EstimateOdometryLagOfLog(const std::string& path);

// "the log pairs each scan with the odometry of the scan 1 after it (... turning scan pairs turn
// nearer the laser so; chance 1e-36)": what a decided lag says to the person replaying the log.
std::string DescribeOdometryLag(const OdometryLag& lag);

// Moves each laser's odometry (and its logged laser pose with it, so that the mounting between
// the two stays) to where the log has it lag_scans scans later: interpolated between the two
// lasers around, clamped at both ends of the vector.
void ShiftOdometry(double lag_scans, std::vector<CarmenLaser>* lasers);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DATASETS_ODOMETRY_LAG_H_

#include "client/datasets/odometry_lag.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>

#include "absl/strings/str_format.h"

namespace waymark::adapters {
namespace {

// Readings beyond this are taken for no-returns wherever the log does not say (FLASER logs
// write 50 m or 81.9 m); closer than kMinRange, for the robot itself.
constexpr double kMaxRange = 40.0;
constexpr double kMinRange = 0.1;
// The laser turned "clearly" between two scans at two beam increments or more.
constexpr int kTurningBeams = 2;
// Turns faster than this per scan are not looked for (rad).
constexpr double kMaxTurnPerScan = 0.35;

double WrapAngle(double a) { return std::remainder(a, 2.0 * M_PI); }

bool Valid(float r, double no_return) {
  return std::isfinite(r) && r > kMinRange && r < kMaxRange && (no_return <= 0 || r < no_return);
}

// Log10 of the chance that a fair coin gives `wins` or more heads in `n` tosses.
double Log10SignTest(int wins, int n) {
  if (n <= 0) return 0.0;
  double log_sum = -INFINITY;  // natural log of the tail's sum
  for (int k = wins; k <= n; ++k) {
    const double term =
        std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0) - n * std::log(2.0);
    log_sum = std::max(log_sum, term) + std::log1p(std::exp(-std::abs(log_sum - term)));
  }
  return std::min(0.0, log_sum / std::log(10.0));
}

// Wall directions, in bins of kBinRad over [0, pi): translation leaves them as they are, so the
// shift between two scans' histograms is the laser's turn alone.
constexpr int kBins = 360;
constexpr double kBinRad = M_PI / kBins;
// Neighbouring points further apart than this lie on different surfaces (m).
constexpr double kMaxNeighbourGap = 0.5;

std::vector<double> DirectionHistogram(const CarmenLaser& l) {
  std::vector<double> raw(kBins, 0.0);
  double px = 0, py = 0;
  bool have = false;
  for (size_t k = 0; k < l.ranges.size(); ++k) {
    const float r = l.ranges[k];
    if (!Valid(r, l.no_return_range)) {
      have = false;
      continue;
    }
    const double bearing = l.angle_min + static_cast<double>(k) * l.angle_increment;
    const double x = r * std::cos(bearing), y = r * std::sin(bearing);
    if (have) {
      const double dx = x - px, dy = y - py, length = std::hypot(dx, dy);
      if (length > 1e-3 && length < kMaxNeighbourGap) {
        double direction = std::atan2(dy, dx);
        if (direction < 0) direction += M_PI;
        const int bin = std::min(kBins - 1, static_cast<int>(direction / kBinRad));
        raw[bin] += length;
      }
    }
    px = x;
    py = y;
    have = true;
  }
  // Smoothed (a direction read from two neighbouring points is a few degrees off).
  std::vector<double> smooth(kBins, 0.0);
  constexpr int kSpread = 4;
  for (int b = 0; b < kBins; ++b) {
    if (raw[b] == 0.0) continue;
    for (int d = -kSpread; d <= kSpread; ++d) {
      smooth[(b + d + kBins) % kBins] += raw[b] * std::exp(-0.5 * d * d / 4.0);
    }
  }
  return smooth;
}

// The shift (rad) that best overlays histogram hb on ha (see ScanRotation).
double HistogramShift(const std::vector<double>& ha, const std::vector<double>& hb,
                      double max_shift_rad) {
  const int max_shift = std::min(kBins / 4, static_cast<int>(max_shift_rad / kBinRad));
  // A robot turning by d sees every wall direction turn by -d: hb(x) = ha(x + d).
  std::vector<double> score(2 * max_shift + 1, 0.0);
  for (int s = -max_shift; s <= max_shift; ++s) {
    double sum = 0.0;
    for (int x = 0; x < kBins; ++x) sum += hb[x] * ha[((x + s) % kBins + kBins) % kBins];
    score[s + max_shift] = sum;
  }
  int best = max_shift;
  for (int i = 0; i < static_cast<int>(score.size()); ++i) {
    if (score[i] > score[best] ||
        (score[i] == score[best] && std::abs(i - max_shift) < std::abs(best - max_shift))) {
      best = i;
    }
  }
  if (!(score[best] > 0.0)) return 0.0;
  double shift = best - max_shift;
  if (best > 0 && best + 1 < static_cast<int>(score.size())) {
    const double down = score[best - 1], up = score[best + 1];
    const double curvature = down - 2.0 * score[best] + up;
    if (curvature < 0.0) shift += 0.5 * (down - up) / curvature;
  }
  return shift * kBinRad;
}

bool HasBeams(const CarmenLaser& l) { return l.ranges.size() >= 10 && l.angle_increment > 0; }

CarmenPose PoseAt(const std::vector<CarmenPose>& poses, double at) {
  const int n = static_cast<int>(poses.size());
  if (n < 2) return poses.front();
  const double clamped = std::clamp(at, 0.0, static_cast<double>(n - 1));
  const int i = std::min(n - 2, static_cast<int>(std::floor(clamped)));
  const double f = clamped - i;
  const CarmenPose& a = poses[i];
  const CarmenPose& b = poses[i + 1];
  return {a.x + f * (b.x - a.x), a.y + f * (b.y - a.y),
          WrapAngle(a.theta + f * WrapAngle(b.theta - a.theta))};
}

// One pose field of every laser (odom_pose or laser_pose).
std::vector<CarmenPose> PosesOf(const std::vector<CarmenLaser>& lasers,
                                CarmenPose CarmenLaser::*field) {
  std::vector<CarmenPose> poses;
  poses.reserve(lasers.size());
  for (const CarmenLaser& l : lasers) poses.push_back(l.*field);
  return poses;
}

}  // namespace

double ScanRotation(const CarmenLaser& a, const CarmenLaser& b, double max_shift_rad) {
  if (!HasBeams(a) || !HasBeams(b)) return 0.0;
  return HistogramShift(DirectionHistogram(a), DirectionHistogram(b), max_shift_rad);
}

void OdometryLagEstimator::Add(const CarmenLaser& laser) {
  window_.push_back(laser);
  if (window_.size() < kWindow) return;
  if (window_.size() > kWindow) {
    window_.pop_front();
    // The pair's first scan was the last pair's second: its histogram, if that pair made one.
    first_histogram_ = std::move(second_histogram_);
  } else {
    first_histogram_.clear();
  }
  second_histogram_.clear();
  // The pair (i, i + 1) with i = kMaxOdometryLagScans, its odometry lagged both ways.
  const int i = kMaxOdometryLagScans;
  Misses turn;
  bool any_turn = false;
  for (int l = 0; l < kLags; ++l) {
    const int lag = l - kMaxOdometryLagScans;
    turn[l] = WrapAngle(window_[i + 1 + lag].odom_pose.theta - window_[i + lag].odom_pose.theta);
    any_turn = any_turn || std::abs(turn[l]) >= kTurningBeams * window_[i].angle_increment;
  }
  if (!any_turn) return;  // no lag would turn: the pair cannot tell them apart
  if (!HasBeams(window_[i]) || !HasBeams(window_[i + 1])) return;
  if (first_histogram_.empty()) first_histogram_ = DirectionHistogram(window_[i]);
  second_histogram_ = DirectionHistogram(window_[i + 1]);
  const double turned = HistogramShift(first_histogram_, second_histogram_, kMaxTurnPerScan);
  if (std::abs(turned) < kTurningBeams * window_[i].angle_increment) return;
  for (int l = 0; l < kLags; ++l) turn[l] = std::abs(WrapAngle(turned - turn[l]));
  misses_.push_back(turn);
}

OdometryLag OdometryLagEstimator::Result() const {
  OdometryLag result;
  result.turning_pairs = static_cast<int>(misses_.size());
  // Whole scans only, one at a time: from 0 towards the side that is nearer, as long as the next
  // lag is nearer than the current one on so many more pairs than the reverse that a fair coin
  // would do as well once in 10^6 tries. (Lags between whole scans would need the odometry
  // interpolated, which smooths its turns and so favours every fractional lag over its
  // neighbours.)
  const auto test = [&](int from, int to, int* wins, int* losses) {
    *wins = 0;
    *losses = 0;
    for (const Misses& m : misses_) {
      *wins += m[to] < m[from];
      *losses += m[to] > m[from];
    }
    return *wins > *losses ? Log10SignTest(*wins, *wins + *losses) : 0.0;
  };
  int current = kMaxOdometryLagScans;
  // The first step: towards the neighbour that beats lag 0 more clearly (the counts reported).
  int step = 0;
  for (const int side : {-1, 1}) {
    int wins = 0, losses = 0;
    const double chance = test(current, current + side, &wins, &losses);
    if (chance < result.log10_chance) {
      result.log10_chance = chance;
      result.for_lag = wins;
      result.for_in_step = losses;
      step = side;
    }
  }
  if (step == 0 || result.log10_chance > kOdometryLagLog10Chance) return result;
  current += step;
  while (current + step >= 0 && current + step < kLags) {
    int wins = 0, losses = 0;
    if (test(current, current + step, &wins, &losses) > kOdometryLagLog10Chance) break;
    current += step;
  }
  result.lag_scans = current - kMaxOdometryLagScans;
  return result;
}

OdometryLag EstimateOdometryLag(const std::vector<CarmenLaser>& lasers) {
  OdometryLagEstimator estimator;
  for (const CarmenLaser& laser : lasers) estimator.Add(laser);
  return estimator.Result();
}

absl::StatusOr<OdometryLag> EstimateOdometryLagOfLog(const std::string& path) {
  auto reader = CarmenLogReader::Open(path);
  if (!reader.ok()) return reader.status();
  OdometryLagEstimator estimator;
  CarmenRecord record;
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&record);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (record.type == CarmenRecord::Type::kLaser) estimator.Add(record.laser);
  }
  return estimator.Result();
}

std::string DescribeOdometryLag(const OdometryLag& lag) {
  return absl::StrFormat(
      "the log pairs each scan with the odometry of the scan %d %s it (%d of %d turning scan "
      "pairs turn nearer the laser so; chance 1e%.0f)",
      std::abs(lag.lag_scans), lag.lag_scans < 0 ? "after" : "before", lag.for_lag,
      lag.for_lag + lag.for_in_step, lag.log10_chance);
}

void ShiftOdometry(double lag_scans, std::vector<CarmenLaser>* lasers) {
  if (lag_scans == 0 || lasers->empty()) return;
  const std::vector<CarmenPose> odometry = PosesOf(*lasers, &CarmenLaser::odom_pose);
  const std::vector<CarmenPose> laser = PosesOf(*lasers, &CarmenLaser::laser_pose);
  for (size_t i = 0; i < lasers->size(); ++i) {
    (*lasers)[i].odom_pose = PoseAt(odometry, static_cast<double>(i) + lag_scans);
    (*lasers)[i].laser_pose = PoseAt(laser, static_cast<double>(i) + lag_scans);
  }
}

}  // namespace waymark::adapters

#ifndef WAYMARK_CLIENT_EVAL_ODOMETRY_NOISE_H_
#define WAYMARK_CLIENT_EVAL_ODOMETRY_NOISE_H_

// Wheel odometry regenerated from a true trajectory with seeded, realistic error, for the
// noisy-odometry benchmark (bench/laser/laser_reference.cc): the scans of a corrected log, the
// truth of its corrected poses, and odometry whose error is known in kind and size.
//
// Per increment u = inv(T_{i-1}) (+) T_i = (dx, dy, dtheta) of the truth, with d = hypot(dx, dy)
// and a = |dtheta|, the odometry sees u' = (dx * k, dy * k, dtheta') with
//   k       = 1 + s * scale_error + scale_jitter * n1            (translation scale error)
//   dtheta' = dtheta * (1 + r * turn_bias) + m * drift_per_m * d  (rotational bias)
//             + sqrt(walk_theta_per_m^2 * d + walk_theta_per_rad^2 * a) * n2
// plus a translational random walk of walk_xy * sqrt(d) * (n3, n4) on (dx, dy): the random parts
// grow with the square root of the increment, so their sum over a path does not depend on how
// finely it is cut into keyframes. s, r, m are signs (+-1) drawn once per log: a robot's scale and
// bias errors are systematic (wheel radii, wheel base), only their direction is unknown. n1..n4
// are standard normal draws. The odometry starts at the true first pose and integrates u'.
//
// The draws come from std::mt19937_64 (fully specified by the standard) through Box-Muller written
// here, not std::normal_distribution (whose algorithm each library chooses): the same seed gives
// the same log on every platform. Every increment draws the same four numbers whatever the
// strength, so the strengths of one seed are the same error pattern at different sizes.

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {

struct OdometryNoise {
  double scale_error = 0;         // systematic translation scale error (fraction)
  double scale_jitter = 0;        // per-increment scale error, standard deviation (fraction)
  double turn_bias = 0;           // systematic rotation scale error (rad per rad turned)
  double drift_per_m = 0;         // systematic heading drift (rad per metre travelled)
  double walk_xy = 0;             // m per sqrt(m travelled)
  double walk_theta_per_m = 0;    // rad per sqrt(m travelled)
  double walk_theta_per_rad = 0;  // rad per sqrt(rad turned)
};

enum class NoiseStrength { kNone, kLow, kMedium, kHigh };

// "none", "low", "medium", "high"; INVALID_ARGUMENT otherwise.
absl::StatusOr<NoiseStrength> ParseNoiseStrength(const std::string& name);
std::string NoiseStrengthName(NoiseStrength strength);
// The benchmark's three levels (see odometry_noise.cc for how they were set); kNone = all zero.
OdometryNoise NoiseFor(NoiseStrength strength);
// "scale_error=0.02 scale_jitter=..." for log headers and reports.
std::string DescribeNoise(const OdometryNoise& noise);

struct NoisyOdometry {
  std::vector<Pose2> poses;  // one per truth pose
  // The signs s, r, m drawn for the log (see the file comment).
  double scale_sign = 1;
  double turn_sign = 1;
  double drift_sign = 1;
};

NoisyOdometry GenerateNoisyOdometry(const std::vector<Pose2>& truth, const OdometryNoise& noise,
                                    uint64_t seed);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_ODOMETRY_NOISE_H_

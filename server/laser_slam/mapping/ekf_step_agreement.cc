#include "server/laser_slam/mapping/ekf_step_agreement.h"

#include <algorithm>
#include <cmath>

namespace waymark::laser_slam {

void EkfStepAgreement::Add(const Eigen::Vector3d& ekf_minus_match,
                           const Eigen::Vector3d& match_variance,
                           const Eigen::Array3i& informative) {
  constexpr double kKeep = 1.0 - 1.0 / kMemorySteps;
  for (int axis = 0; axis < 3; ++axis) {
    if (!informative(axis) || !std::isfinite(ekf_minus_match(axis)) ||
        !std::isfinite(match_variance(axis))) {
      continue;
    }
    // Not clipped: a wrong association (a step metres off) keeps the EKF distrusted for the
    // memory's length, which is the safe side.
    const double squared = ekf_minus_match(axis) * ekf_minus_match(axis);
    difference_(axis) = kKeep * difference_(axis) + ekf_minus_match(axis);
    disagreement_(axis) = kKeep * disagreement_(axis) + squared;
    match_(axis) = kKeep * match_(axis) + match_variance(axis);
    weight_(axis) = kKeep * weight_(axis) + 1.0;
  }
}

namespace {

// The weight of the kMinSteps newest steps in the exponential window: what an axis needs.
double MinimumWeight() {
  const double keep = 1.0 - 1.0 / EkfStepAgreement::kMemorySteps;
  return (1.0 - std::pow(keep, EkfStepAgreement::kMinSteps)) / (1.0 - keep) - 1e-9;
}

}  // namespace

std::optional<double> EkfStepAgreement::EkfVariance(int axis, double floor) const {
  if (weight_(axis) < MinimumWeight()) return std::nullopt;
  return std::max(floor, (disagreement_(axis) - match_(axis)) / weight_(axis));
}

std::optional<double> EkfStepAgreement::MatchVariance(int axis) const {
  if (weight_(axis) < MinimumWeight()) return std::nullopt;
  return match_(axis) / weight_(axis);
}

bool EkfStepAgreement::Biased(int axis, double sigmas) const {
  const double n = weight_(axis);
  if (n < MinimumWeight()) return true;
  const double mean = difference_(axis) / n;
  const double spread = std::max(0.0, disagreement_(axis) / n - mean * mean);
  return mean * mean > sigmas * sigmas * spread / n;
}

void EkfStepAgreement::Values(double (&values)[kValues]) const {
  for (int axis = 0; axis < 3; ++axis) {
    values[axis] = disagreement_(axis);
    values[3 + axis] = match_(axis);
    values[6 + axis] = weight_(axis);
    values[9 + axis] = difference_(axis);
  }
}

std::optional<EkfStepAgreement> EkfStepAgreement::FromValues(const double (&values)[kValues]) {
  EkfStepAgreement a;
  for (int i = 0; i < kValues; ++i) {
    // The sums of differences (the last three) may be negative.
    if (!std::isfinite(values[i]) || (i < 9 && values[i] < 0.0)) return std::nullopt;
  }
  for (int axis = 0; axis < 3; ++axis) {
    a.disagreement_(axis) = values[axis];
    a.match_(axis) = values[3 + axis];
    a.weight_(axis) = values[6 + axis];
    a.difference_(axis) = values[9 + axis];
  }
  // The weight of an exponential window never exceeds its memory.
  if ((a.weight_ > kMemorySteps + 1e-6).any()) return std::nullopt;
  return a;
}

}  // namespace waymark::laser_slam

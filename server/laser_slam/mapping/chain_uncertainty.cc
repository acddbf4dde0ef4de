#include "server/laser_slam/mapping/chain_uncertainty.h"

#include <algorithm>
#include <cmath>

namespace waymark::laser_slam {

void ChainUncertainty::Append(const Eigen::Vector2d& position, const Eigen::Vector3d& step_sigma) {
  Prefix next;
  next.position = position;
  if (!prefix_.empty()) {
    next = prefix_.back();
    next.position = position;
    // The step's heading error turns the robot at the previous node, where the step starts.
    const Eigen::Vector2d pivot = prefix_.back().position;
    const double s = step_sigma(2) * step_sigma(2);
    next.xy += std::max(step_sigma(0), step_sigma(1)) * std::max(step_sigma(0), step_sigma(1));
    next.s += s;
    next.p += s * pivot;
    next.r += s * pivot.squaredNorm();
  }
  prefix_.push_back(next);
}

ChainUncertainty::Sigma ChainUncertainty::Between(int a, int b) const {
  Sigma out;
  if (a < 0 || b >= size() || a >= b) return out;
  const Prefix& pa = prefix_[a];
  const Prefix& pb = prefix_[b];
  const double s = pb.s - pa.s;
  const Eigen::Vector2d p = pb.p - pa.p;
  const double r = pb.r - pa.r;
  const double swing = pb.position.squaredNorm() * s - 2.0 * pb.position.dot(p) + r;
  out.theta = std::sqrt(std::max(0.0, s));
  out.xy = std::sqrt(std::max(0.0, pb.xy - pa.xy + swing));
  return out;
}

}  // namespace waymark::laser_slam

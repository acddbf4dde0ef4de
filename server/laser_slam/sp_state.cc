#include "server/laser_slam/sp_state.h"

#include <algorithm>

namespace waymark::laser_slam {

SpState::SpState() {
  Reserve(64);
  n_ = 3;  // the robot
  storage_.topLeftCorner(3, 3).setZero();
}

SpState& SpState::operator=(const SpState& other) {
  if (this == &other) return *this;
  AssignLowerTriangle(other);
  storage_.topLeftCorner(n_, n_).triangularView<Eigen::StrictlyUpper>() =
      other.storage_.topLeftCorner(n_, n_).triangularView<Eigen::StrictlyUpper>();
  return *this;
}

void SpState::AssignLowerTriangle(const SpState& other) {
  if (this == &other) return;
  robot = other.robot;
  segments = other.segments;
  frozen = other.frozen;
  n_ = 0;  // nothing of the old covariance is kept by a Reserve
  Reserve(other.n_);
  n_ = other.n_;
  // Column by column, the part on and below the diagonal: contiguous in column-major storage.
  for (int j = 0; j < n_; ++j) {
    storage_.col(j).segment(j, n_ - j) = other.storage_.col(j).segment(j, n_ - j);
  }
}

void SpState::Reserve(int capacity) {
  if (storage_.rows() >= capacity) return;
  Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(capacity, capacity);
  if (n_ > 0) grown.topLeftCorner(n_, n_) = storage_.topLeftCorner(n_, n_);
  storage_.swap(grown);
}

int SpState::AddDofs(int k) {
  // Grow geometrically so that augmenting one segment at a time stays amortised O(n^2) overall.
  if (n_ + k > storage_.rows()) Reserve(std::max<int>(n_ + k, static_cast<int>(storage_.rows()) * 2));
  const int first = n_;
  n_ += k;
  storage_.block(first, 0, k, n_).setZero();
  storage_.block(0, first, n_, k).setZero();
  return first;
}

void SpState::RemoveDofs(std::vector<int> dofs) {
  // Remove from the highest index down; each hole is filled by the current last dof.
  std::sort(dofs.begin(), dofs.end(), std::greater<int>());
  for (int hole : dofs) {
    const int last = n_ - 1;
    if (hole != last) {
      storage_.row(hole).head(n_).swap(storage_.row(last).head(n_));
      storage_.col(hole).head(n_).swap(storage_.col(last).head(n_));
      // Point whoever owned `last` at `hole`.
      for (SegmentEntity& s : segments) {
        for (int& d : s.dof) {
          if (d == last) d = hole;
        }
      }
    }
    --n_;
  }
}

std::vector<int> SegmentDofs(const SegmentEntity& segment) {
  std::vector<int> dofs;
  for (int d : segment.dof) {
    if (d >= 0) dofs.push_back(d);
  }
  return dofs;
}

}  // namespace waymark::laser_slam

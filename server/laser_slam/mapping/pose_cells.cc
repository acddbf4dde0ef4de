#include "server/laser_slam/mapping/pose_cells.h"

#include <cmath>
#include <cstddef>

namespace waymark::laser_slam {

PoseCells::PoseCells(const std::vector<Pose2>& poses, const std::vector<int>& owner, double radius)
    : poses_(poses), owner_(owner), radius_(radius) {
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const auto [cx, cy] = Cell(poses[k].x, poses[k].y);
    cells_[Pack(cx, cy)].push_back(static_cast<int>(k));
  }
}

int PoseCells::NearestOther(int self, const Pose2& at) const {
  int best = -1;
  double best_sq = radius_ * radius_;
  const auto [cx, cy] = Cell(at.x, at.y);
  for (std::int64_t dx = -1; dx <= 1; ++dx) {
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      const auto it = cells_.find(Pack(cx + dx, cy + dy));
      if (it == cells_.end()) continue;
      for (const int k : it->second) {
        if (owner_[k] == self) continue;
        const Pose2& p = poses_[k];
        const double sq = (p.x - at.x) * (p.x - at.x) + (p.y - at.y) * (p.y - at.y);
        if (sq <= best_sq) {
          best_sq = sq;
          best = k;
        }
      }
    }
  }
  return best;
}

std::pair<std::int64_t, std::int64_t> PoseCells::Cell(double x, double y) const {
  return {static_cast<std::int64_t>(std::floor(x / radius_)),
          static_cast<std::int64_t>(std::floor(y / radius_))};
}

std::uint64_t PoseCells::Pack(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx) << 32) ^ (static_cast<std::uint64_t>(cy) & 0xffffffffu);
}

}  // namespace waymark::laser_slam

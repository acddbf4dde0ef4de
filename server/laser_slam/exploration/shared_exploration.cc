#include "server/laser_slam/exploration/shared_exploration.h"

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {

void MergeTeammates(const std::vector<Teammate>& teammates, double body_radius,
                    ExplorationGrid* grid) {
  for (const Teammate& t : teammates) {
    if (t.snapshot == nullptr) continue;
    grid->FillUnknownFrom(t.snapshot->grid, t.to_here);
  }
  // After every fill: a robot this one saw where a teammate stood left occupied cells in this
  // robot's own grid, which the fill does not overwrite.
  for (const Teammate& t : teammates) {
    if (t.snapshot == nullptr) continue;
    for (const Eigen::Vector2d& p : t.snapshot->stood) {
      grid->FreeOccupiedDisc(MoveBy(t.to_here, p), body_radius);
    }
    grid->FreeOccupiedDisc(MoveBy(t.to_here, Eigen::Vector2d(t.snapshot->robot.x,
                                                             t.snapshot->robot.y)),
                           body_radius);
  }
}

std::vector<MapSegment> WithTeammateSegments(const std::vector<MapSegment>& own,
                                             const std::vector<Teammate>& teammates) {
  std::vector<MapSegment> out = own;
  for (const Teammate& t : teammates) {
    if (t.snapshot == nullptr) continue;
    for (MapSegment s : t.snapshot->segments) {
      s.frame = Compose(t.to_here, s.frame);
      out.push_back(s);
    }
  }
  return out;
}

}  // namespace waymark::laser_slam

#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_OBSERVATION_PREDICTION_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_OBSERVATION_PREDICTION_H_

// The predicted observation of the current map from a hypothetical robot pose (METHODS.md section
// 2, J21 and J22): how far the next scan would extend mapped segments past their virtual endpoints
// and how many virtual endpoints it would turn real.
//
// Model (ours; the paper defines the quantities, not how to predict them):
// - The laser sees a map point when it is within range, inside the field of view, not hidden
//   behind a mapped segment (a ray cast of the map over the scan's own beams) and not at a grazing
//   angle the line extraction would drop (min_incidence).
// - Beyond a virtual endpoint the wall is presumed to go on along the segment's line. The
//   predicted extension is how much further the visible run from the endpoint outwards reaches
//   than it does from the robot's current pose (the last scan was taken there and did not extend
//   the segment, so what it saw past the end is not wall: a range-cut wall end facing open space
//   would otherwise attract the robot for ever), provided the laser also sees the mapped segment
//   next to the endpoint (so the observation would match it). Gains under min_extension count as
//   zero.
// - Where another mapped line crosses within corner_reach past a virtual endpoint (at an angle
//   over corner_angle, the crossing within corner_reach of that segment), a corner is predicted:
//   the extension stops there, and if the run reaches it (and does not from the current pose) the
//   endpoint is predicted to turn real.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/exploration_types.h"

namespace waymark::laser_slam {

struct ExplorationGain {
  double extension = 0.0;      // sum of predicted virtual extensions V(j) (m)
  int new_real_endpoints = 0;  // virtual endpoints predicted to turn real
};

struct MapTotals {
  double length = 0.0;  // sum of segment lengths L(i) (m)
  int segments = 0;     // m
  int real_endpoints = 0;
};

MapTotals Totals(const std::vector<MapSegment>& segments);

class ObservationPredictor {
 public:
  // Selects the segments and virtual endpoints that a scan from within `travel` metres of the
  // robot could see; Predict() then only looks at those.
  ObservationPredictor(const ExplorationView& view, const ExplorationOptions& options,
                       double travel);

  // The gain of a scan taken with the robot at `robot` (map frame).
  ExplorationGain Predict(const Pose2& robot) const;

  int frontier_count() const { return static_cast<int>(frontiers_.size()); }
  int occluder_count() const { return static_cast<int>(occluders_.size()); }

 private:
  struct Frontier {
    Eigen::Vector2d endpoint;   // the virtual endpoint (map frame)
    Eigen::Vector2d outward;    // unit vector along the line, away from the segment
    double back = 0.0;          // how far inside the segment the laser must also see
    double reach = 0.0;         // how far past the endpoint to look
    bool corner = false;        // reach ends at a predicted corner
  };

  struct Run {
    double length = 0.0;  // visible run past the endpoint (m)
    bool corner = false;  // the run reaches a predicted corner
  };
  Run RunOf(const Frontier& f, const Pose2& laser, const std::vector<double>& ranges) const;
  // Ranges of the map seen from `laser` (map frame) over the scan's beams.
  std::vector<double> CastMap(const Pose2& laser) const;
  bool Visible(const Pose2& laser, const std::vector<double>& ranges,
               const Eigen::Vector2d& point, const Eigen::Vector2d& line_direction) const;

  ExplorationOptions options_;
  ScanGeometry beams_;
  Pose2 laser_pose_;
  double max_range_;
  double min_incidence_sin_;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> occluders_;
  std::vector<Frontier> frontiers_;
  std::vector<Run> seen_now_;  // per frontier, from the robot's current pose
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_OBSERVATION_PREDICTION_H_

#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_H_

// One pose graph over every tied-in trajectory of a shared map (issue 38; docs/laser-slam.md,
// "The map's own pose graph").
//
// Placed one at a time (origin_smoothing.h), each followed robot is bent to meet the map, and the
// map holds still: a loop the first robot left open stays open, and the robot that closes it is
// bent to meet both of its ends (ACES split at 10 %: the first robot's start and end areas 4-6 m
// apart in its own map). Here every trajectory's nodes are variables of one graph:
// - each trajectory's chain: its nodes' current relative poses, with its session's chain sigmas
//   (NodeView::step_sigma), as in origin_smoothing.h; and its session's loop closures
//   (TiedTrajectory::loops), also at the current relative poses with their own sigmas. At rest
//   the trajectory keeps its session's shape, as stiff as its own closures make it: a chain
//   alone let one robot's samples bend a well-closed map (ACES split at 50 %: the first robot
//   0.042 -> 0.048 m against its own relations);
// - each follow sample (and the tie) a constraint between the followed node and the nearest node
//   of another trajectory where the one-at-a-time placement, which the follow matched against,
//   had it: the match observed the node relative to the map around it, and that map can now move.
//   A sample with no other node within anchor_radius ties the node to the map frame, as before;
// - the gauge: the first trajectory's (the map frame's) first node, where it is.
// A sample's sigma is a loop closure's, under the same Huber loss. No constant is fitted here.

#include <vector>

#include "server/laser_slam/mapping/origin_smoothing.h"
#include "server/laser_slam/mapping/trajectory_tie.h"

namespace waymark::laser_slam {

struct MapGraphOptions {
  OriginSmoothingOptions samples;  // sigmas, Huber, iterations: as one robot's graph
  // A sample's anchor: the nearest node of another trajectory within this distance (m) of the
  // observed pose, about a scan's reach (the follow matched against points that far).
  double anchor_radius = 5.0;
};

// For each trajectory (same order; the first is the map frame's), one sample per node (oldest
// first): matched, the node's solved map pose, the origin there. A trajectory whose nodes the
// graph could not place (no nodes) gets none; where the solver fails, every trajectory keeps the
// one-at-a-time placement (NodesInMapFrame).
std::vector<std::vector<OriginSample>> SolveMapGraph(const std::vector<TiedTrajectory>& trajectories,
                                                     const MapGraphOptions& options = {});

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_H_

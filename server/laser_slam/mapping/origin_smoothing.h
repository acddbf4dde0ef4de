#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_ORIGIN_SMOOTHING_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_ORIGIN_SMOOTHING_H_

// A followed robot's map-frame poses from a pose graph of its own nodes (issue 38;
// docs/laser-slam.md, "Maps shared by robots").
//
// The follow (trajectory_follow.h) observes the robot's origin in the map at some of its nodes,
// one match each. Interpolating the origin between those samples has two faults:
// - each sample is one match, and the origin between two samples jumps by that match's error
//   (ACES split at 10 and 25 %: the second robot alone 0.066-0.080 m with the follow, 0.045 m
//   without);
// - where the robot drives off the others' map for a long stretch, the correction that the
//   samples at both ends call for is spread by turning the whole session frame about its origin,
//   often far from the robot, not along the path as a single session's closure spreads it.
//
// Here every sample is a constraint in a pose graph of the robot's nodes, as a loop closure is
// in its own session's graph (loop_sigma_xy / loop_sigma_theta, under the same Huber loss), and
// consecutive nodes keep their current relative poses with the sigmas of the session's own
// chain constraints (each node's step_sigma, or the chain sigmas' defaults where a node has
// none). The solution is the node's pose in the map frame; the origin at a node is that pose
// (-) the node's own. The other trajectories stay as they are (a graph of the one robot, with
// the map as its fixed root), so nothing already in the map moves.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/pose_graph.h"
#include "server/laser_slam/mapping/trajectory_follow.h"

namespace waymark::laser_slam {

struct OriginSmoothingOptions {
  // 1 sigma of a sample's observed map-frame pose: a loop closure's in the session's graph
  // (MappingOptions::loop_sigma_xy / loop_sigma_theta), since a follow-up match is one.
  double sample_sigma_xy = 0.05;
  double sample_sigma_theta = 0.01;
  double huber_scale = 1.0;  // MappingOptions::huber_scale
  int max_iterations = 30;

  Eigen::Vector3d sample_sigma() const {
    return Eigen::Vector3d(sample_sigma_xy, sample_sigma_xy, sample_sigma_theta);
  }
};

// The sigma of the step to `node` from the one before (`step`: the relative pose): its own (the
// session's chain constraint), or, where it has none, the session graph's default chain sigmas.
Eigen::Vector3d ChainStepSigma(const NodeView& node, const Pose2& step);

// Appends the chain of `nodes` (oldest first) to a pose graph whose pose first_pose + i is node i:
// consecutive nodes at their current relative poses, each step with its ChainStepSigma.
void AppendChain(const std::vector<NodeView>& nodes, int first_pose,
                 std::vector<GraphConstraint>* constraints);

// The index of the node of `nodes` (by scan, oldest first) with scan `scan`; -1: none (pruned).
int NodeOfScan(const std::vector<NodeView>& nodes, std::uint64_t scan);
// What a sample observed: the node's map-frame pose (the tie's sample has no matched pose: its
// origin at the node is the observation).
Pose2 ObservedMapPose(const OriginSample& sample, const NodeView& node);
// A node placed at `map_pose`: a matched sample with the origin there.
OriginSample PlacedNode(const NodeView& node, const Pose2& map_pose);

// One sample per node of `nodes` (oldest first, by scan; matched, with the node's solved map
// pose, and the origin there from the node's current pose), from the follow's `samples` (the
// tie's first). A sample whose scan is not among the nodes (a pruned node) is left out of the
// graph. Without nodes or without a sample on one of them: `samples` with their origins derived
// again (RefreshOrigins), as before.
std::vector<OriginSample> SmoothOrigins(const std::vector<NodeView>& nodes,
                                        const std::vector<OriginSample>& samples,
                                        const OriginSmoothingOptions& options = {});

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_ORIGIN_SMOOTHING_H_

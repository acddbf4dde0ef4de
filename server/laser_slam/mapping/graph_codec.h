#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_GRAPH_CODEC_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_GRAPH_CODEC_H_

// The fields a pose graph is stored with (the back end's checkpoint, mapping_backend_checkpoint.cc,
// and the node feed of a shared map, node_feed_codec.h): poses, constraints and a node's points,
// written with BinaryWriter and read back with checks, so that bytes from a database or another
// server never give a pose off the map, a constraint between nodes that do not exist or a sigma
// that is not positive.

#include <cstdint>

#include "server/common/binary_io.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/pose_graph.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

void PutPose(BinaryWriter& w, const Pose2& p);
// A stored pose, within the bounds of a map (input_bounds.h).
bool GetPose(BinaryReader& r, Pose2* p);

// Three stored variances (or sigmas): finite and not negative.
bool GetVariance(BinaryReader& r, Eigen::Vector3d* v);

void PutConstraint(BinaryWriter& w, const GraphConstraint& c);
// A stored constraint between two of the `nodes` nodes, with positive finite sigmas.
bool GetConstraint(BinaryReader& r, int nodes, GraphConstraint* c);

// A node's points (robot frame): their count, then x and y as floats.
void PutPoints(BinaryWriter& w, const PointCloud& points);
// At most `max_points`, each within a robot's reach (input_bounds.h); the count is checked
// against the bytes left before anything is allocated.
bool GetPoints(BinaryReader& r, std::uint32_t max_points, PointCloud* points);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_GRAPH_CODEC_H_

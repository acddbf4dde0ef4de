#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_SEGMENTS_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_SEGMENTS_H_

// The segment map of a map shared by robots (issue 38; docs/laser-slam.md, "Maps shared by
// robots"): every tied-in trajectory's segments moved into the map frame, and a wall that two
// robots both mapped fused into one segment.
//
// Each session's filter already fused its own sightings of a wall (SegmentEkf::MergeSegments),
// so only segments of different trajectories are fused here. Two are the same wall when their
// lines agree within their own uncertainties (the filters' line covariances, plus the
// uncertainty of where a trajectory lies in the map: `placement_sigma_*`) by a chi-square test at
// `gate_probability`, and their extents overlap along the line: collinear walls with a doorway
// between them stay two. The fused line is the information-weighted mean of the two; its extent
// spans both. Plain C++: the server gathers the segments, this decides.

#include <cstdint>
#include <vector>

#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/laser_slam/mapping/trajectory_tie.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct MapSegmentsOptions {
  // How well a trajectory's place in the map is known, beyond its segments' own covariances
  // (1 sigma of the line's offset and of its direction): the follow's matches agree to 1-2 cm
  // (docs/results.md, "One map for two robots"), the loop closures' sigma is 5 cm / 0.01 rad.
  double placement_sigma_xy = 0.05;
  double placement_sigma_theta = 0.01;
  // The chance a segment pair of one wall fails the test (2 degrees of freedom).
  double gate_probability = 0.99;
};

// A segment of one trajectory, in the map frame.
struct PlacedSegment {
  MapSegment segment;
  int trajectory = 0;
};

struct MergedSegments {
  std::vector<MapSegment> segments;  // in the map frame
  // Per segment, the trajectories it holds a wall of (one, or several when fused).
  std::vector<std::vector<int>> trajectories;
  int fused = 0;  // segments fused into another one
};

// `segment` (in its trajectory's map frame) in the shared map's frame: its frame moved by the
// trajectory's origin at the segment's last sighting (OriginAt over `samples`, by the stamp
// `stamp_of_last_sighting`; `origin` without samples). Line covariance and extent are the
// frame's own, so they move with it unchanged.
MapSegment SegmentInMapFrame(const MapSegment& segment, const Pose2& origin,
                             const std::vector<OriginSample>& samples,
                             double stamp_of_last_sighting);

// A trajectory's segments (its session's map frame) in the shared map's frame, each by the
// origin at the stamp of the node at or before its last sighting (CurrentOrigins, as
// NodesInMapFrame places the nodes).
std::vector<MapSegment> SegmentsInMapFrame(const TiedTrajectory& trajectory,
                                           const std::vector<MapSegment>& segments);
// The same with the trajectory's origins given (NodesPlacedBy: one per node from the map's
// graph, or samples; empty: `origin`).
std::vector<MapSegment> SegmentsInMapFrame(const TiedTrajectory& trajectory,
                                           const std::vector<MapSegment>& segments,
                                           const std::vector<OriginSample>& origins);

// Fuses the segments of different trajectories that map the same wall (see above), longest
// first; a fused segment takes no second segment of a trajectory it already holds.
MergedSegments MergeTrajectorySegments(std::vector<PlacedSegment> segments,
                                       const MapSegmentsOptions& options = {});

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_SEGMENTS_H_

#ifndef WAYMARK_CLIENT_CLI_MAP_FRAME_H_
#define WAYMARK_CLIENT_CLI_MAP_FRAME_H_

// A session's poses in its shared map's frame (issue 38; docs/laser-slam.md, "Maps shared by
// robots"): the trajectory's origin, or, when the server followed the robot after its tie, the
// origin at each pose's stamp, interpolated between the server's origins at the session's nodes
// (MapTrajectory.node_origins), or between the follow's samples where it sent none. Used by
// `slam trajectory --frame map` and by the tracks `map grid` draws.

#include <vector>

#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// The trajectory's node origins (else its origin samples), each matched one's origin derived
// again from the session's current pose at its stamp (`poses`): the node's map-frame pose (-)
// that pose, since the session's own closures may have moved the node since. Samples with no
// map-frame pose, or no pose at their stamp, keep theirs.
std::vector<v1::MapOriginSample> CurrentOriginSamples(const v1::MapTrajectory& t,
                                                      const v1::Trajectory& poses);

// The origin at `stamp`: the samples interpolated in stamp, held before the first and after the
// last; without samples the trajectory's origin.
v1::Pose2D OriginAt(const v1::MapTrajectory& t, const std::vector<v1::MapOriginSample>& samples,
                    double stamp);

// Moves `trajectory` (the session's own poses, GetTrajectory) into the map frame of `t`, its
// entry in the map. The caller checks that it is tied in.
void MoveToMapFrame(const v1::MapTrajectory& t, v1::Trajectory* trajectory);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_MAP_FRAME_H_

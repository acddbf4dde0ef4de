#ifndef WAYMARK_SERVER_SERVICE_SLAM_MAP_FOLLOW_CODEC_H_
#define WAYMARK_SERVER_SERVICE_SLAM_MAP_FOLLOW_CODEC_H_

// A trajectory's follow in a shared map (issue 38: the origin samples after its tie, how the
// matching went, and how the searches up to the tie went) as the map store keeps it
// (storage::MapTrajectoryRecord::follow: a MapTrajectory message with only origin_samples, follow
// and search set, serialized) and as the API shows it, and the warning a trajectory's counts call
// for.

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/laser_slam/mapping/trajectory_tie.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

struct StoredFollow {
  std::vector<laser_slam::OriginSample> samples;
  v1::MapMatchStats stats;
  // The global searches that found the robot, up to its tie (MapTrajectory.search): stored with
  // the tie, before any sample, so that a map can still say after the tie that it was found among
  // look-alike places.
  v1::MapMatchStats search;
};

std::string EncodeFollow(const StoredFollow& follow);
// DATA_LOSS for bytes that are not such a message, or samples out of stamp order or not finite.
absl::StatusOr<StoredFollow> DecodeFollow(const std::string& bytes);

// MapTrajectory.origin_samples (and node_origins) <-> the follow's samples (no checks: messages
// this server made).
void SetSample(const laser_slam::OriginSample& sample, v1::MapOriginSample* out);
std::vector<laser_slam::OriginSample> SamplesOf(const v1::MapTrajectory& trajectory);

v1::MapMatchStats StatsOf(const laser_slam::FollowProgress& progress);
v1::MapMatchStats StatsOf(const laser_slam::TieProgress& progress);
// Field by field: the counts of two follows one after the other.
v1::MapMatchStats Sum(const v1::MapMatchStats& a, const v1::MapMatchStats& b);

// Why the map is unsure of `trajectory` (MapTrajectory.warning), from its counts; empty if not:
// - not yet in the map, and searches found look-alike places (a tie waits until one place wins);
// - tied in, and searches before its tie found look-alike places: the place it was tied in at
//   may be one of them (in a floor with point symmetry a half-turned robot's follow-up matches
//   hold as well as a right one's, docs/results.md);
// - followed, and fewer than half of at least 10 follow-up matches held: between the ones that
//   did its map-frame pose drifts with its odometry.
std::string MapTrajectoryWarning(const v1::MapTrajectory& trajectory);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_MAP_FOLLOW_CODEC_H_

#ifndef WAYMARK_CLIENT_EVAL_EXPLORATION_METRICS_H_
#define WAYMARK_CLIENT_EVAL_EXPLORATION_METRICS_H_

// How well a simulated exploration went, measured against the simulator's ground truth: the frames
// that put the SLAM map and the wheel odometry into the world, localisation error, and map
// completeness (issue 4: "the share of the true wall length that lies within 0.1 m of a mapped
// segment").

#include <vector>

#include "client/sim/sim_reach.h"
#include "client/sim/sim_world.h"
#include "client/render/map_render.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {

// A rigid transform into the world frame: world = Compose(world_from_frame, local).
struct FrameTransform {
  Pose2 world_from_frame;

  Pose2 Apply(const Pose2& local) const;
  Vec2 Apply(const Vec2& local) const;
  SceneSegment Apply(const SceneSegment& local) const;  // keeps the endpoint types

  // The SLAM map frame is the robot frame at the first processed scan, so the true pose at that
  // scan places the map in the world.
  static FrameTransform MapToWorld(const Pose2& true_pose_at_first_scan);
  // Wheel odometry is anchored the same way: at the first scan its pose meets the true one, and
  // from then on it drifts on its own. That makes "odometry only" comparable with the estimate.
  static FrameTransform OdometryToWorld(const Pose2& true_pose_at_first_scan,
                                        const Pose2& odometry_at_first_scan);
};

// Distance between two positions (headings ignored), m.
double PositionError(const Pose2& truth, const Pose2& estimate);

struct CompletenessOptions {
  double sample_step = 0.02;  // m between wall samples
  double tolerance = 0.1;     // m: a sample is mapped when a segment is at most this far
};

// The share in [0, 1] of the total wall length whose samples lie within `tolerance` of some mapped
// segment (both in the world frame). Each wall is cut into equal pieces of at most `sample_step`
// and each piece counts with its length when its midpoint is covered, so a map equal to the walls
// scores exactly 1. Segments with non-finite endpoints are ignored; no walls scores 0.
double Completeness(const std::vector<adapters::Wall>& walls,
                    const std::vector<SceneSegment>& mapped,
                    const CompletenessOptions& options = {});

// Completeness of what can be seen: the share in [0, 1] of the visible wall length (samples from
// adapters::VisibleWalls, per world) whose samples lie within `tolerance` of some mapped segment
// (options.sample_step is the samples' own). Some wall length is never seen from where the robot
// fits (behind a cabinet, or only from spots it cannot reach), so Completeness stays below 1 for
// any explorer; this reaches 1 for a map of everything seen. No visible walls scores 0.
double CompletenessOfVisible(const std::vector<adapters::WallSample>& visible,
                             const std::vector<SceneSegment>& mapped,
                             const CompletenessOptions& options = {});

// Distance from point p to the segment a-b (a point when a == b).
double PointSegmentDistance(const Vec2& p, const Vec2& a, const Vec2& b);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_EXPLORATION_METRICS_H_

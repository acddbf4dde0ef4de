#ifndef WAYMARK_CLIENT_ROS_FRAME_TREE_H_
#define WAYMARK_CLIENT_ROS_FRAME_TREE_H_

// The planar part of a bag's TF tree, as a laser replay needs it:
//   - static edges (tf_static, or the latest value seen on /tf) for the laser's mounting: the
//     chain from the robot's base frame down to the laser frame;
//   - dynamic edges over time (a child frame's pose in its parent at each stamp), for odometry
//     (odom -> base_link), looked up between two samples by interpolation.
// Frames are compared without a leading '/'. Poses are planar: x, y and the yaw of the 3D
// transform (a roll or pitch beyond kMaxTilt is reported, since a tilted laser's scan is not a
// horizontal slice).

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/tum_trajectory.h"  // Pose2
#include "client/ros/ros_messages.h"

namespace waymark::ros {

inline constexpr double kMaxTilt = 0.1;  // rad of roll or pitch

// a (+) b, inv(a) and the pose at fraction t from a to b (the shorter turn).
cli::Pose2 Compose2(const cli::Pose2& a, const cli::Pose2& b);
cli::Pose2 Inverse2(const cli::Pose2& a);
cli::Pose2 Interpolate2(const cli::Pose2& a, const cli::Pose2& b, double t);

// The planar pose of a 3D transform, and its tilt (the larger of |roll| and |pitch|).
cli::Pose2 PlanarPose(const Vector3& translation, const Quaternion& rotation);
double TiltOf(const Quaternion& rotation);

// One moving frame's pose in its parent over time, in stamp order, bounded.
class PoseHistory {
 public:
  static constexpr size_t kMaxSamples = 100000;

  // Inserted in stamp order (a sample repeating a stamp replaces it). Beyond kMaxSamples the
  // oldest is dropped (and counted).
  void Add(int64_t stamp_ns, const cli::Pose2& pose);
  // The pose at `stamp_ns`: interpolated between the samples around it, the last one when the
  // stamp is at most `hold_ns` after it; nullopt when before the first sample or too far after
  // the last.
  std::optional<cli::Pose2> At(int64_t stamp_ns, int64_t hold_ns) const;
  // Drops samples no lookup at or after `stamp_ns` needs (keeps the last one at or before it).
  void PruneBefore(int64_t stamp_ns);

  bool empty() const { return samples_.empty(); }
  int64_t first_ns() const { return samples_.front().first; }
  int64_t last_ns() const { return samples_.back().first; }
  int64_t dropped() const { return dropped_; }
  int64_t reordered() const { return reordered_; }

 private:
  std::deque<std::pair<int64_t, cli::Pose2>> samples_;
  int64_t dropped_ = 0;
  int64_t reordered_ = 0;
};

class FrameTree {
 public:
  // A transform of `child` in `parent`. Static ones (tf_static) are kept for good; dynamic ones
  // (/tf) go into the child's history and also count as its latest fixed value.
  void AddStatic(const TransformStampedMsg& transform);
  void AddDynamic(const TransformStampedMsg& transform);

  // The top of `frame`'s chain of static parents (`frame` itself without one).
  std::string StaticRoot(const std::string& frame) const;
  // The pose of `child` in its ancestor `ancestor` through static edges (and the latest value of
  // /tf edges when `allow_latest`); NOT_FOUND naming the missing link.
  absl::StatusOr<cli::Pose2> FixedChain(const std::string& ancestor, const std::string& child,
                                        bool allow_latest) const;
  // The largest tilt met on that chain (see kMaxTilt).
  double ChainTilt(const std::string& ancestor, const std::string& child) const;

  // The parent `child` moves in (/tf), empty if none; several parents are all listed.
  std::vector<std::string> DynamicParents(const std::string& child) const;
  PoseHistory* History(const std::string& child);
  // "map -> odom, odom -> base_link" (dynamic) for messages.
  std::string DescribeDynamic() const;
  std::string DescribeStatic() const;

  void PruneBefore(int64_t stamp_ns);

 private:
  struct Edge {
    std::string parent;
    cli::Pose2 pose;
    double tilt = 0;
  };
  struct Moving {
    std::vector<std::string> parents;
    PoseHistory history;
    Edge latest;
  };
  const Edge* FixedEdge(const std::string& child, bool allow_latest) const;

  std::map<std::string, Edge> static_;   // by child frame
  std::map<std::string, Moving> moving_;  // by child frame
};

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_FRAME_TREE_H_

#ifndef WAYMARK_SERVER_VISUAL_SLAM_MAPPING_LOCAL_MAP_H_
#define WAYMARK_SERVER_VISUAL_SLAM_MAPPING_LOCAL_MAP_H_

// The window of recent keyframes a session refines with a local bundle adjustment (beyond the
// paper, which has none): each keyframe's pose and the features it mapped, each feature on a
// track (the same scene point seen from several keyframes, followed through the matches of
// tracking). A job is a snapshot of the window as a bundle problem: it can run on another thread
// while tracking goes on, and its answer is applied later by keyframe and track ids.
//
// Gauge: the oldest keyframe of the window is held (RGB-D: depth fixes the scale), the two oldest
// monocular (the second fixes the scale). Points start from a previous adjustment, else from depth
// (RGB-D) or by triangulating their two farthest-apart observations (monocular).
//
// Not thread-safe: the session's strand builds jobs and applies them; a job itself is plain data.

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "server/common/binary_io.h"
#include "server/visual_slam/frame_features.h"
#include "server/visual_slam/mapping/bundle_adjustment.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct LocalMapOptions {
  int window = 8;  // keyframes adjusted together (ORB-SLAM2's covisible window is 10-20)
  // A track becomes a point once seen by this many keyframes of the window.
  int min_observations = 2;
  // Monocular triangulation needs this angle (degrees) between the two rays.
  double min_parallax_deg = 0.5;
  BundleOptions bundle;
};

struct BundleJob {
  BundleProblem problem;
  std::vector<int64_t> keyframe_ids;  // per problem camera
  std::vector<int64_t> point_tracks;  // per problem point
  // Per problem observation: the keyframe id and that keyframe's feature index.
  std::vector<std::pair<int64_t, int>> observation_features;
};

class LocalMap {
 public:
  LocalMap(const LocalMapOptions& options, bool monocular);

  // Adds a keyframe. `tracks`: per feature, the track it continues, or -1 for a new one;
  // `in_map`: per feature, whether it may become a point (a candidate on a boxed object may not).
  // Returns every feature's track id (new ones assigned here). Keyframes beyond the window leave.
  std::vector<int64_t> AddKeyframe(int64_t id, const Pose& pose, const FrameFeatures& features,
                                   const std::vector<int64_t>& tracks,
                                   const std::vector<bool>& in_map);

  // Lets feature `feature` of keyframe `id` (still in the window) become a point on `track`: a
  // candidate that was kept out when its keyframe was added and has since passed the static test
  // (join_static_boxed). Does nothing for a keyframe no longer in the window, a feature out of
  // range or a negative track.
  void Admit(int64_t id, int feature, int64_t track);

  // A snapshot of the window as a bundle problem; nullopt when the window is too small for the
  // gauge or has too few points.
  std::optional<BundleJob> MakeJob() const;

  // Applies an adjustment: keyframes still in the window take their new poses, those added while
  // it ran move the way its newest keyframe moved, tracks take their points, and outlier
  // observations leave their tracks.
  void Apply(const BundleJob& job, const BundleResult& result);

  // The pose of a keyframe still in the window.
  std::optional<Pose> PoseOf(int64_t id) const;

  // The adjusted world point of a track, once it has one.
  std::optional<Eigen::Vector3d> Point(int64_t track) const;
  int keyframes() const { return static_cast<int>(keyframes_.size()); }
  const BundleOptions& bundle_options() const { return options_.bundle; }
  int points() const { return static_cast<int>(points_.size()); }

  // The window and its points for the session's checkpoint, and back: Load replaces this map
  // with the saved one and returns false (leaving this map unchanged) on truncated, oversized or
  // non-finite input.
  void Save(BinaryWriter& out) const;
  bool Load(BinaryReader& in);

 private:
  struct Keyframe {
    int64_t id = 0;
    Pose pose;
    std::vector<Eigen::Vector2d> normalized;
    std::vector<std::optional<double>> depth;
    std::vector<int64_t> track;  // -1: not on a track that may become a point
  };
  std::optional<Eigen::Vector3d> InitialPoint(
      const std::vector<std::pair<const Keyframe*, int>>& seen) const;

  LocalMapOptions options_;
  bool monocular_;
  std::deque<Keyframe> keyframes_;  // oldest first
  std::unordered_map<int64_t, Eigen::Vector3d> points_;
  int64_t next_track_ = 0;
};

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_MAPPING_LOCAL_MAP_H_

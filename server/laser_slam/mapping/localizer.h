#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_

// Localization on a fixed map (docs/laser-slam.md, "Localization"): the EKF keeps tracking the
// robot in its local frame, and every node_travel the newest scans are matched against the map's
// likelihood field around where the current correction puts them. Each accepted match resets the
// correction (map <- local). Without a known start, or after too long without a match, the match
// is a branch-and-bound search over the whole map and all headings; a fix from it is accepted only
// when two consecutive global searches agree with the motion between them (one match in a
// building of similar rooms is too often the wrong room).

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct LocalizationOptions {
  // Where the robot starts in the map frame; unset = unknown (global search first).
  std::optional<Pose2> initial_pose;
  double initial_sigma_xy = 0.5;
  double initial_sigma_theta = 0.2;
  // Match every this much motion (m, rad), with the points of the last query_nodes such scans
  // together (global search) and of the last track_query_nodes (tracking), placed by the EKF's
  // relative motion. Several scans tell a corridor's length apart where one cannot: on Intel's
  // first 3000 scans, localized on its exported grid, 5 scans gave 10 poses off by more than
  // 0.5 m, 3 gave 32 and 1 gave 44 (docs/results.md).
  double node_travel = 0.25;
  double node_turn = 0.15;
  int query_nodes = 5;
  int track_query_nodes = 5;
  double point_range = 12.0;
  double point_cell = 0.05;
  double grid_resolution = 0.05;
  double grid_sigma = 0.05;
  // Tracking window: 3 sigma, sigma = base + drift * metres since the last fix.
  double track_sigma_xy = 0.1;
  double track_sigma_theta = 0.03;
  double drift_xy_per_m = 0.02;
  double drift_theta_per_m = 0.005;
  double min_score = 0.55;  // a tracking match
  // Global search: a stricter score, and the agreement of two consecutive searches (m, rad).
  double global_min_score = 0.65;
  double global_agreement_xy = 0.3;
  double global_agreement_theta = 0.1;
  int global_depth = 5;
  // The global search runs on a grid this many times coarser (and then refines on the fine one):
  // fewer cells, fewer points and fewer headings make it about 8x cheaper.
  int global_coarsening = 2;
  // Lost: this far (m) without an accepted match, the next match is global again.
  double lost_after_m = 10.0;
};

absl::Status ValidateLocalizationOptions(const LocalizationOptions& options);

struct LocalizationResult {
  bool localized = false;
  double score = 0.0;        // of the last match tried (0 when none)
  int fixes = 0;             // accepted matches
  double last_fix_stamp = 0.0;
  bool global_search = false;  // this scan ran a global search
  double match_ms = 0.0;
};

class MapLocalizer {
 public:
  // `map_points` in the map frame (e.g. a session's nodes at their optimised poses, or the
  // occupied cells of an imported grid). FAILED_PRECONDITION for an empty map.
  static absl::StatusOr<std::unique_ptr<MapLocalizer>> Create(const LocalizationOptions& options,
                                                              const PointCloud& map_points);

  // A processed scan: 1-based index, stamp, EKF pose, points in the robot frame.
  LocalizationResult AddScan(std::uint64_t scan, double stamp, const Pose2& local,
                             const PointCloud& points);
  // `local` (an EKF pose of scan `scan`) in the map frame. Before the first fix: the initial
  // pose's correction if one was given, else the first fix's (retroactively), else identity.
  Pose2 ToMap(std::uint64_t scan, const Pose2& local) const;
  LocalizationResult last() const { return last_; }

  // The correction history and counters (the query window restarts on resume).
  std::string Serialize() const;
  absl::Status Restore(absl::string_view bytes);

 private:
  MapLocalizer(const LocalizationOptions& options, SearchPyramid pyramid, SearchPyramid coarse);
  void Accept(std::uint64_t scan, double stamp, const Pose2& correction, double score);

  struct QueryNode {
    Pose2 local;
    PointCloud points;
  };
  const LocalizationOptions options_;
  const SearchPyramid pyramid_;  // tracking and refinement (depth 6)
  const SearchPyramid coarse_;   // global search
  std::deque<QueryNode> recent_;
  Pose2 last_node_local_;
  bool have_node_ = false;
  double travel_ = 0.0;
  double fix_travel_ = 0.0;      // travel at the last accepted match
  bool localized_ = false;
  // The correction of a global match waiting for the next one to agree with it.
  std::optional<Pose2> pending_global_;
  // (scan, correction) from each accepted match on, in scan order.
  std::vector<std::pair<std::uint64_t, Pose2>> corrections_;
  LocalizationResult last_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_

#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_

// Localization on a fixed map (docs/laser-slam.md, "Localization"): the EKF keeps tracking the
// robot in its local frame, and every node_travel the newest scans are matched against the map's
// likelihood field around where the current correction puts them. Each accepted match resets the
// correction (map <- local). Without a known start, or after too long without a match, the match
// is a branch-and-bound search over the whole map and all headings (global_localization.h); a fix
// from it is accepted only when two consecutive global searches agree with the motion between
// them (one match in a building of similar rooms is too often the wrong room) and neither has a
// rival place far from it that scores nearly as well (two rooms alike, a corridor that slides).
// Every match carries its confidence: its score and its best rival's. The global search never
// runs whole inside AddScan: it gets a budget per scan, inline (threads = 0) or on the
// localizer's own thread (threads = 1).

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/mapping/global_localization.h"
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
  // The global search runs on a grid this many times coarser (and then refines on the fine one),
  // with the query thinned to one point per global_query_cell: its cost is in proportion to the
  // cells, the headings (one per cell at the query's far end) and the points. Measured with one
  // search at every 150th scan of ACES, Intel and MIT CSAIL, on their maps and exported grids
  // (306 searches): 4x and 0.3 m cost 86-145 M cell reads a search, 2x and 0.3 m 166-335 M, 2x
  // and 0.1 m (the old setting; CSAIL and Intel) 441-927 M. Matches unique but wrong: 4 of 306 at
  // 4x, 1 at 2x; a fix needs two searches that agree.
  int global_coarsening = 4;
  double global_query_cell = 0.3;
  // Lost: this far (m) without an accepted match, the next match is global again.
  double lost_after_m = 10.0;

  // Ambiguity. A rival of a global match (or of the first match from a known start) is the best
  // pose of the same search farther than rival_xy or rival_theta from it: another place. Rivals
  // are searched for down to rival_floor times the match's score; a match whose rival reaches
  // global_rival_ratio of it is refused. 0.9 is the back end's rival_ratio for closures
  // (mapping_options.h); 1 m / 0.5 rad put a rival in another place, not on the match's own peak
  // (0.5 rad moves points 2-12 m away by 1-6 m). A tracking match's rival, reported and never
  // refused, is how far it could slide: the best pose at its heading farther than track_rival_xy.
  double rival_xy = 1.0;
  double rival_theta = 0.5;
  double rival_floor = 0.8;
  double global_rival_ratio = 0.9;
  double track_rival_xy = 0.2;

  // Cost. 0 = the global search runs inside AddScan, global_reads_per_scan at a time
  // (deterministic: tests, evaluations); 1 = on the localizer's own thread, that much per scan the
  // session processes (the server's setting: at a robot's pace no answer waits on it; a scan
  // waits only while the thread is two budgets behind, as in a replay faster than real time). One
  // read is one point of one candidate pose (1-3 ns here): 4 M reads take 5-10 ms, and a search
  // over ACES, Intel or MIT CSAIL's map 20-40 processed scans.
  int threads = 0;
  std::int64_t global_reads_per_scan = 4'000'000;
};

absl::Status ValidateLocalizationOptions(const LocalizationOptions& options);

// Where the localizer stands after a scan.
enum class LocalizationState {
  kFromStart,   // known start, not matched yet: dead reckoning from the initial pose
  kSearching,   // not localized: a search over the whole map is under way
  kConfirming,  // not localized: one global match, waiting for the next search to agree with it
  kAmbiguous,   // not localized: the last global match had a rival place (rival_*) and was refused
  kTracking,    // localized
};

struct LocalizationResult {
  bool localized = false;
  LocalizationState state = LocalizationState::kSearching;
  double score = 0.0;        // of the last match tried (0 when none)
  // Its ambiguity: the best rival's lattice score over the match's (0..1; 1 = another pose fits
  // as well), 0 when no rival reaches rival_floor; where that rival is, from the match (m, rad).
  double rival_ratio = 0.0;
  double rival_distance = 0.0;
  double rival_angle = 0.0;
  int fixes = 0;             // accepted matches
  double last_fix_stamp = 0.0;
  bool global_search = false;  // this scan worked on (or took the answer of) a global search
  double match_ms = 0.0;
};

class MapLocalizer {
 public:
  // `map_points` in the map frame (e.g. a session's nodes at their optimised poses, or the
  // occupied cells of an imported grid). FAILED_PRECONDITION for an empty map.
  static absl::StatusOr<std::unique_ptr<MapLocalizer>> Create(const LocalizationOptions& options,
                                                              const PointCloud& map_points);
  ~MapLocalizer();  // stops the global search's thread
  MapLocalizer(const MapLocalizer&) = delete;
  MapLocalizer& operator=(const MapLocalizer&) = delete;

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
  // A fix for scan `scan`, whose node was at `travel` metres.
  void Accept(std::uint64_t scan, double stamp, const Pose2& correction, double score,
              double travel);
  // A tracking match (or the first match from a known start) around the current correction.
  void Track(std::uint64_t scan, double stamp, const Pose2& local, bool from_initial);
  // A finished global search's answer: a fix, a candidate waiting for agreement, or a refusal.
  void TakeGlobalAnswer(const GlobalSearch& search);
  // The points of the newest `count` nodes, in the newest one's frame.
  PointCloud Query(int count, const Pose2& local) const;

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
  double search_travel_ = 0.0;   // travel at the node of the global search under way
  // (scan, correction) from each accepted match on, in scan order.
  std::vector<std::pair<std::uint64_t, Pose2>> corrections_;
  LocalizationResult last_;
  // Declared last: its thread reads the pyramids above and stops before they go.
  GlobalSearchRunner global_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCALIZER_H_

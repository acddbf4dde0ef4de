#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_TIE_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_TIE_H_

// Where a robot that joined a shared map is in it (issue 38; docs/laser-slam.md, "Maps shared by
// robots"): the transform from the joining trajectory's own frame (its session's map frame) to
// the shared map's frame, found from its scans alone. No start pose is needed.
//
// The map is what the tied-in trajectories hold: their nodes' points at their graph poses, moved
// into the map frame by each trajectory's origin, drawn into one likelihood grid (and a coarser
// one for the search). The joining trajectory's newest nodes are searched for over the whole map
// and every heading (GlobalSearch, the localizer's resumable branch and bound) under a budget of
// cell reads, one search after the other. A match counts only when no rival place far from it
// scores nearly as well (two look-alike rooms, a corridor seen the other way round: either
// could be the robot's). And one unique match is not enough: the localizer measured 4 wrong
// unique matches in 306 searches on real maps. The tie needs two matches of nodes that share no
// scan and lie at least min_separation metres of travel apart which agree, through the joining
// trajectory's own motion between them, on the same transform within the localizer's
// agreement (0.3 m, 0.1 rad). A wrong match must then be repeated, at another place, with the
// same error. The agreed transform is refined once with the points of every node between the two
// (a longer stretch of wall pins it better than five scans).
//
// Plain C++, no threads: the caller decides when to run it and with how much budget (the server
// runs it on its own thread, a budget per scan the joining session processed, so that no answer
// waits on it: server/service/slam/map_tie_worker.h).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/global_localization.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/pose_graph.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct TieOptions {
  // The query: the points of the newest query_nodes nodes in the newest one's frame (as the
  // localizer's global search: several scans tell a corridor's length apart where one cannot).
  int query_nodes = 5;
  int min_query_points = 30;  // fewer (a robot in the open) wait for the next node
  // The map's grids: fine (refinement) and global_coarsening times coarser (the search), the
  // query thinned to global_query_cell there. The localizer's measured settings (localizer.h).
  double point_cell = 0.05;
  double grid_resolution = 0.05;
  double grid_sigma = 0.05;
  int global_coarsening = 4;
  int global_depth = 5;
  double global_query_cell = 0.3;
  double min_score = 0.65;
  // Rivals: a pose farther than rival_xy / rival_theta from the match scoring at least
  // rival_ratio of it makes the match ambiguous (the back end's and the localizer's 0.9).
  double rival_xy = 1.0;
  double rival_theta = 0.5;
  double rival_floor = 0.8;
  double rival_ratio = 0.9;
  // Two matches agree when the first, carried by the joining trajectory's motion to the second
  // node, lands within these of the second match (and the other way round).
  double agreement_xy = 0.3;
  double agreement_theta = 0.1;
  // Travel (m) between the two agreeing nodes: the same place searched twice is no evidence.
  double min_separation = 2.0;
  // The final refinement: at most this many nodes, in a window of this size around the agreed
  // transform.
  int refine_nodes = 25;
  double refine_window_xy = 0.3;
  double refine_window_theta = 0.05;
  // Unique matches kept to agree with later ones (the oldest go first).
  int max_candidates = 8;
  // A tie needs more of the kept unique matches (the fresh one included) to agree with its
  // transform than to disagree with it: where most "unique" matches point elsewhere, the rival
  // test is not catching this place's look-alikes (a shift along a straight facade is the same
  // for two matches), and two agreeing ones are no evidence. false: the first agreeing pair ties
  // (as before; freiburg-campus-corrected-medium split for two robots was tied 5.4 m off after
  // 6 disagreeing pairs).
  bool outvote_disagreements = true;
  // The map's grids are drawn again before the next search once the map holds this fraction
  // more nodes than when they were drawn (a tied-in robot still exploring widens the map).
  double map_growth = 0.1;
  // The budget: cell reads granted per scan the joining robot processes (the localizer's
  // global_reads_per_scan: 4 M reads are 5-10 ms here, a scan period 25-200 ms), or per second
  // of the robot's own clock (its stamps) where that is more (search_clock.h): 20 M is what
  // reads_per_scan gives a 5 Hz scanner, so a log of keyframes a metre apart gets its searches
  // by the second. 0: the scans alone.
  std::int64_t reads_per_scan = 4'000'000;
  std::int64_t reads_per_second = 20'000'000;
};

absl::Status ValidateTieOptions(const TieOptions& options);

// One tied-in trajectory of the map: its nodes (their graph poses in its own frame) and where
// that frame lies in the map frame.
struct TiedTrajectory {
  Pose2 origin;
  std::vector<NodeView> nodes;
  // When followed after its tie (trajectory_follow.h): the follow's samples, from which the
  // origin at each node comes (CurrentOrigins), in place of `origin`. Empty: `origin` for every
  // node.
  std::vector<OriginSample> samples;
  // Its session graph's loop closures in force, by node index (what holds its shape in the map's
  // graph, map_graph.h); empty where not read.
  std::vector<GraphConstraint> loops;
};

// Whether tying `joining` (its nodes in its own frame) in at `tie` leaves the map consistent:
// where the map self-check (map_consistency.h) finds the tied-in trajectories' nodes and the
// joining ones each consistent on their own, it must find them consistent together, the joining
// ones placed by `tie`. Where either contradicts itself already, the check cannot tell (true). A robot tied into a look-alike place its map does not hold yet (a floor
// with point symmetry, a corridor ring) still contradicts the map wherever else its own scans
// overlap it: its walls in the map's free space and the other way round. `why` (may be null)
// says what was found.
bool TieKeepsTheMapConsistent(const std::vector<TiedTrajectory>& map,
                              const std::vector<NodeView>& joining, const Pose2& tie,
                              std::string* why);

// The trajectory's own loop closures that are in force and name two of its nodes.
std::vector<GraphConstraint> LoopsInForce(const TiedTrajectory& trajectory);

// The origins a followed trajectory is placed by now: its samples smoothed through a pose graph
// of its current nodes (origin_smoothing.h), one per node. Not followed (no samples): empty.
std::vector<OriginSample> CurrentOrigins(const TiedTrajectory& trajectory);

// A tied-in trajectory's nodes moved into the map frame: each by its origin (CurrentOrigins)
// where the trajectory is followed, else by `origin`.
std::vector<NodeView> NodesInMapFrame(const TiedTrajectory& trajectory);
// The same with the trajectory's origins given: one per node (CurrentOrigins, or the map's
// graph, map_graph.h: each node at its map_pose), or samples interpolated by stamp; empty:
// `origin` for every node.
std::vector<NodeView> NodesPlacedBy(const TiedTrajectory& trajectory,
                                    const std::vector<OriginSample>& origins);

// The tied-in trajectories' nodes in the map frame with the distance along each trajectory
// (trajectory = its index in `trajectories`): what a follow's window adds for the map's drift.
std::vector<MapPathPoint> MapPath(const std::vector<TiedTrajectory>& trajectories);

// The tied-in trajectories' points in the map frame, thinned to one per `cell`.
PointCloud MapCloud(const std::vector<TiedTrajectory>& trajectories, double cell);

enum class TieState {
  kWaiting,     // no map yet, or too few nodes to search with
  kSearching,   // a search under way, or the last one found nothing
  kCandidate,   // unique matches found, none yet agreeing with another
  kAmbiguous,   // the last match had a rival place and was refused
  kTied,        // two matches agreed: tie() holds the transform
};

struct TieProgress {
  TieState state = TieState::kWaiting;
  int searches = 0;       // global searches finished
  int matches = 0;        // ... with a unique match (a candidate)
  int ambiguous = 0;      // ... refused for a rival place
  int disagreements = 0;  // candidate pairs far enough apart that did not agree
  int outvoted = 0;       // agreeing pairs not taken: more kept matches disagreed with them
  int refused = 0;        // ties found and refused for contradicting the map (Refuse)
  double last_score = 0.0;
  double last_rival_ratio = 0.0;  // the last match's rival's score over its own (0: none)
  std::int64_t reads = 0;         // cell reads spent in all
  // The scan the searches' clock stands at: the budget of the scans up to it is spent.
  double clock_scan = 0.0;
  // Once tied: the joining trajectory's frame in the map frame (map = tie (+) session), the
  // scan of the node that completed it, and the scan at which the robot had it (the clock's
  // scan when the search that completed it ended: a robot at its own pace is tied in then).
  std::optional<Pose2> tie;
  std::uint64_t tie_scan = 0;
  std::uint64_t tied_at_scan = 0;
};

// How the kept unique matches vote on a fresh one's transform: for each, newest first, whether it
// is independent of the fresh one (no shared scan, far enough along) and agrees with it. Returns
// the newest independent agreeing one's index to tie with, or -1: none agrees, or (with
// `outvote`) the agreeing ones and the fresh one are not more than the disagreeing ones.
struct TieVote {
  bool independent = false;
  bool agrees = false;
};
int TieWinner(const std::vector<TieVote>& votes, bool outvote);

class TrajectoryTie {
 public:
  static absl::StatusOr<std::unique_ptr<TrajectoryTie>> Create(const TieOptions& options);
  TrajectoryTie(const TrajectoryTie&) = delete;
  TrajectoryTie& operator=(const TrajectoryTie&) = delete;

  // Whether SetMap should be called with a map of `map_nodes` nodes: none yet, or it grew by
  // map_growth since the grids were drawn.
  bool WantsMap(std::size_t map_nodes) const;
  // The map to search in (MapCloud of the tied-in trajectories). A search under way goes on in
  // the grids it started with; the next one uses these. INVALID_ARGUMENT for a map too large.
  absl::Status SetMap(const PointCloud& map_points, std::size_t map_nodes);

  // Goes on with the searches, spending at most `max_reads` cell reads now (about: the
  // refinements are a few windowed matches) of what the joining robot's scans granted.
  // `joining`: its nodes as its session's graph places them now, oldest first
  // (MappingBackend::Nodes): node i must stay node i from call to call. Nothing more once tied.
  //
  // The searches run on a clock of scans, not of calls: reads_per_scan for every scan since the
  // first node (or reads_per_second for the seconds between them, search_clock.h), and each new search is for the newest node at or before the scan the clock has
  // reached (a scan period with nothing new to search is not saved up). So the same scans give
  // the same searches and the same tie however the calls are spread: a replay at 200 times real
  // time and a robot at its own pace are tied in at the same scan, the replay later in seconds
  // (the caller's thread then catches up, at most the scans' budget behind).
  const TieProgress& Advance(const std::vector<NodeView>& joining, std::int64_t max_reads);
  const TieProgress& progress() const { return progress_; }
  // The tie found is refused (TieKeepsTheMapConsistent said no): it is dropped with the unique
  // matches kept, and the searches go on.
  void Refuse();

 private:
  struct Grids;
  struct Candidate {
    int node = 0;        // index in the joining trajectory
    Pose2 match;         // the node's pose in the map frame
    double score = 0.0;
  };
  explicit TrajectoryTie(const TieOptions& options) : options_(options) {}
  // The points of nodes [first, last] in node `last`'s frame (their current graph poses).
  PointCloud Query(const std::vector<NodeView>& joining, int first, int last, double cell) const;
  // A search for node `node` (its query has too few points: none, and false).
  bool StartSearch(const std::vector<NodeView>& joining, int node);
  void TakeAnswer(const std::vector<NodeView>& joining);
  // Whether candidates a and b (a older) agree through the joining trajectory's motion.
  bool Agree(const std::vector<NodeView>& joining, const Candidate& a, const Candidate& b) const;
  // The agreed transform refined with the nodes from a's query to b.
  Pose2 Refine(const std::vector<NodeView>& joining, const Candidate& a, const Candidate& b) const;

  const TieOptions options_;
  std::shared_ptr<const Grids> grids_;  // the newest map
  std::size_t grid_nodes_ = 0;          // the map's nodes when grids_ was drawn
  std::shared_ptr<const Grids> search_grids_;  // what search_ reads (it must outlive it)
  std::unique_ptr<GlobalSearch> search_;
  int search_node_ = -1;  // the node search_ (or the last search) was for
  std::vector<Candidate> candidates_;
  TieProgress progress_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_TRAJECTORY_TIE_H_

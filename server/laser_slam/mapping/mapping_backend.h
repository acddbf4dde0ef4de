#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_MAPPING_BACKEND_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_MAPPING_BACKEND_H_

// The loop-closing back end of a laser session (docs/laser-slam.md, "Loop closure").
//
// The paper's EKF stays the local estimator and gives poses in its own frame, the "local" frame,
// which drifts. Every scan after the robot moved node_travel / node_turn becomes a node: its
// local pose and its points. Consecutive nodes are tied by the EKF's relative motion (chain
// constraints); nodes are grouped into submaps of submap_nodes; a new node is matched against
// complete older submaps by branch-and-bound correlative matching (loop constraints). A pose graph
// over the nodes (Ceres) gives each node a "global" pose in the map frame. A local pose taken at
// a scan is mapped to the map frame through the correction of the newest node at or before it:
// global(node) (+) (-)local(node) (+) pose.
//
// With threads = 1, submap grids, loop searches and optimisations run on the back end's own
// thread, so AddScan only appends a node; with threads = 0 they run inside AddScan. The thread
// handles every node in order, however far behind the stream it falls (a replay sent at 100x
// real time), and sees the graph as the inline back end would: both give the same map.
// Thread-safe: every public method may be called from any thread.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_set>
#include <unordered_map>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/mapping/chain_uncertainty.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/ekf_step_agreement.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/local_matcher.h"
#include "server/laser_slam/mapping/loop_search.h"
#include "server/laser_slam/mapping/mapping_options.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/pose_graph.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// What the base's odometry says the robot did since the previous processed scan: the increment
// the EKF was given (robot frame; zero after an odometry reset) and its error covariance. The
// front end's prior: the EKF's own step is better when its walls are right, and arbitrarily wrong
// when it associates wrongly (on logs with metres between scans, its steps were 5x worse than the
// odometry's: docs/results.md), so local matching starts from the odometry and its honest noise.
struct ScanMotion {
  Pose2 increment;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

// A node as the map and the grids need it.
struct NodeView {
  std::uint64_t scan = 0;  // 1-based index of the scan in the session
  double stamp = 0.0;
  Pose2 global;            // map frame
  std::shared_ptr<const PointCloud> points;  // robot frame
  // 1 sigma of the chain step from the node before (x, y, theta); zero where none is known yet.
  Eigen::Vector3d step_sigma = Eigen::Vector3d::Zero();
};

struct MappingStats {
  int nodes = 0;
  int submaps = 0;
  int searches = 0;             // loop searches (one per searched node)
  int candidates = 0;           // submaps matched
  int closures_accepted = 0;    // loop constraints added
  int closures_rejected = 0;    // candidates with no pose above min_score
  int closures_ambiguous = 0;   // matches refused: a rival place (rival_far away) fits as well
  int closures_loosened = 0;    // accepted with their sigma widened to a near rival
  int closures_where_seen = 0;  // matches accepted on the points where the submap looked
  int global_searches = 0;      // searches over whole submaps (the window outgrew max_window_xy)
  int closures_switched_off = 0;  // accepted, then found inconsistent by the graph
  int optimizations = 0;
  int local_matches = 0;        // nodes whose chain constraint comes from local matching
  int local_unmatched = 0;      // nodes left with the prior's step (nothing scored local_min_score)
  int local_odometry_wins = 0;  // matches around the odometry's step that beat the EKF's
  int local_widened = 0;  // matches taken from the wide window (local_widen_at_heading_edge)
  // Of those, steps the odometry chained (local_unmatched_odometry): the EKF's was off.
  int local_unmatched_odometry = 0;
  int local_ekf_trusted = 0;    // steps whose EKF was trusted on an axis (ekf_step_agreement.h)
  int local_edge_translations_dropped = 0;  // matches on their window's edge, translation unused
  int local_ekf_redecided = 0;  // earlier steps made the EKF's when it was first trusted
  int closures_pending = 0;     // global matches held for a second match (confirm_global_closures)
  int closures_unconfirmed = 0; // of those, dropped: no agreeing match within confirm_within_nodes
  int submaps_pruned = 0;       // redundant submaps pruned (MappingOptions::prune_redundant_submaps)
  int nodes_pruned = 0;         // their nodes, out of the graph, their points dropped
  int graph_nodes = 0;          // nodes in the pose graph: nodes - nodes_pruned
  int pending_nodes = 0;        // waiting for the back end's thread (filled by Stats())
  std::vector<double> search_ms;    // per searched node, all candidates
  std::vector<double> optimize_ms;  // per optimisation
  std::vector<double> local_ms;     // per locally matched node
};

class MappingBackend {
 public:
  // `options` must pass ValidateMappingOptions.
  explicit MappingBackend(const MappingOptions& options);
  ~MappingBackend();
  MappingBackend(const MappingBackend&) = delete;
  MappingBackend& operator=(const MappingBackend&) = delete;

  // A processed scan: its 1-based index, stamp, EKF pose and points (robot frame). Becomes a
  // node when the robot moved enough since the last node (always for the first).
  void AddScan(std::uint64_t scan, double stamp, const Pose2& local, const PointCloud& points,
               const ScanMotion& motion);
  // The same with the EKF's own motion as the odometry (tests of the graph's bookkeeping).
  void AddScan(std::uint64_t scan, double stamp, const Pose2& local, const PointCloud& points);

  // `local`, the robot's EKF pose at scan `scan`, in the map frame.
  Pose2 ToGlobal(std::uint64_t scan, const Pose2& local) const;
  // The transform from the local to the map frame at scan `scan`, where the robot's EKF pose was
  // `robot`: ToGlobal(s, p) = it (+) p. A node's own; between two nodes, the one before's, moved
  // towards the one after's as far as the robot is along the way (MappingOptions::
  // interpolate_corrections); after the newest node, the newest's. Anything of the EKF's frame
  // seen at that scan (a segment) moves with it.
  Pose2 CorrectionAt(std::uint64_t scan, const Pose2& robot) const;

  // Waits until the thread has handled every node, then optimises once more if any loop
  // constraint came since the last optimisation. The graph is then final for these scans.
  void Flush();

  // Waits until the thread has handled every node appended so far (no extra optimisation): a
  // node's pose changes when local matching handles it.
  void WaitForPending() const;

  // Every node in scan order; a pruned node's points are empty (it still maps its scans' poses).
  std::vector<NodeView> Nodes() const;
  std::vector<GraphConstraint> Constraints() const;
  // Copies the per-search and per-optimisation times: not for every scan.
  MappingStats Stats() const;
  // Loop constraints in the graph (accepted and not switched off); cheap.
  int loop_closures() const;
  // Increases with every optimisation that moved the nodes.
  std::uint64_t revision() const;

  // Versioned binary of nodes, submaps, constraints and counters (the grids are rebuilt from the
  // points on demand). Call after Flush for a complete graph; pending nodes are included.
  std::string Serialize() const;
  static absl::StatusOr<std::unique_ptr<MappingBackend>> Deserialize(const MappingOptions& options,
                                                                      absl::string_view bytes);

 private:
  struct Node {
    std::uint64_t scan = 0;
    double stamp = 0.0;
    double travel = 0.0;  // EKF path length at the node
    Pose2 local;
    Pose2 global;
    std::shared_ptr<const PointCloud> points;
    Pose2 odometry;  // dead reckoning of the odometry increments, own frame
    Eigen::Vector3d odometry_variance = Eigen::Vector3d::Zero();  // of the step from the previous
    // A pruned node is out of the graph. It follows the kept nodes around its pruned stretch: at
    // `from_anchor` of `anchor` (before it) and at `from_after` of `after` (after it), blended by
    // its share `weight` of the travel between them, so that its pose moves with both ends.
    bool pruned = false;
    int anchor = -1;
    int after = -1;
    Pose2 from_anchor;
    Pose2 from_after;
    double weight = 0.0;
    // 1 sigma of the chain step that reached it, once processed (chain_'s, kept for checkpoints:
    // a pruned node's chain constraint is gone).
    Eigen::Vector3d chain_sigma = Eigen::Vector3d::Zero();
  };
  struct Submap {
    int first = 0;  // node indices [first, first + count)
    int count = 0;
    bool complete = false;
    // The nodes' poses relative to the first one, fixed when its last node was handled: its grid
    // is drawn with them, so a grid built once stays right (Cartographer's finished submaps) and
    // does not depend on when it was built.
    std::vector<Pose2> frozen;
    bool decided = false;  // the pruning's decision taken (prune_redundant_submaps)
    bool pruned = false;
  };

  // Appends the node and its chain constraint; returns its index. Caller holds mu_.
  int AppendNodeLocked(std::uint64_t scan, double stamp, const Pose2& local,
                       const PointCloud& points);  // takes the odometry from dead_reckoning_
  // Submap bookkeeping, the loop search for node `index` and, when due, an optimisation.
  // Takes mu_ itself, briefly.
  void Process(int index);
  // The front end: node `index`'s scan against the nodes before it (local_matcher.h); sets its
  // chain constraint and its pose, and moves the nodes after it along.
  void MatchLocalMap(int index);
  // Where the session has shown the EKF's steps better than the matches on an axis
  // (ekf_step_agreement.h), fuses the match again with the EKF's step trusted to its learned
  // variance there; then records the step's disagreement. Caller holds search_mu_
  // (ekf_agreement_ is the front end's).
  struct EkfTrust {
    int axes = 0;                      // on which the EKF's step was trusted
    bool translation_dropped = false;  // an edge match's
    Eigen::Vector3d variance = Eigen::Vector3d::Zero();  // of the prior the match was fused with
  };
  EkfTrust TrustEkfWhereShown(const Pose2& ekf_step, const Eigen::Vector3d& ekf_minus_odometry,
                              const Eigen::Vector3d& odometry_sigma,
                              const Eigen::Vector3d& prior_sigma, LocalMatchResult* match);
  // The first time the session shows its EKF better than its matches on every axis (node
  // `index`), the steps before, fused while nothing was known, are decided again: the EKF's step,
  // to `variance`, where it stayed within the odometry's noise. An early heading error turns the
  // whole map (5 mrad at the simulator's first turns in place put the corridor's far end 0.1 m
  // off). Only while the graph is the chain alone. Caller holds mu_ and search_mu_.
  void RedecideEarlierStepsLocked(int index, const Eigen::Vector3d& variance);
  // The least sigmas (x, y, theta) a front-end step is trusted to (local_sigma_xy / _theta).
  Eigen::Vector3d LocalSigmaFloor() const;
  // The local search window of a step with these sigmas (x, y, theta).
  SearchWindow LocalWindow(const Eigen::Vector3d& sigma) const;
  void SearchLoops(int index);
  // Optimises the graph of nodes [0, upto] and carries the later nodes along.
  void Optimize(int upto);
  // Decides, for every complete submap with prune_after_submaps newer complete ones processed
  // (their last node at or before `index`: not the stream's progress, which the thread lags), whether it
  // is kept (its points join coverage_) or pruned. Caller holds mu_ and search_mu_.
  void DecidePruningLocked(int index);
  // Adds a loop constraint moved off pruned nodes, merged into an enabled one between the same
  // two nodes if there is one. Caller holds mu_.
  void MergeLoopLocked(const GraphConstraint& loop);
  // A pruned node's pose from its two kept ends. Caller holds mu_.
  Pose2 PrunedPoseLocked(const Node& node) const;
  // Takes the submap's nodes out of the graph (see MappingOptions::prune_redundant_submaps).
  // Caller holds mu_ and search_mu_.
  void PruneSubmapLocked(int submap);
  // Appends the prune_cell cells of the node's points at its global pose.
  void AppendCoverageCells(const Node& node, std::vector<Eigen::Vector2i>* cells) const;
  // Whether at least prune_min_ties of the submap's nodes have an enabled loop constraint from an
  // older kept submap. Caller holds mu_.
  bool TiedToKeptMapLocked(int submap) const;
  // The submap's points in its first node's frame, as a search pyramid (cached).
  // `coarsening` 1: the search grid; coarse_search_factor: the coarse one of global searches.
  // Caller holds search_mu_ (the cache is the searches').
  std::shared_ptr<const SearchPyramid> PyramidFor(int submap, int coarsening);
  // The lattice of the submap's search grid, without building it (what a global search covers).
  GridFrame FineFrameOf(int submap);
  // Where the submap's scans looked (seen_mask.h), in its first node's frame; the newest
  // kSeenMasksKept are kept. Caller holds search_mu_.
  std::shared_ptr<const SeenMask> SeenMaskFor(int submap);
  // The submap's points in its first node's frame (at its frozen poses once complete).
  PointCloud SubmapCloud(int submap) const;
  // Node j of submap `s` in its first node's frame (`anchor`: that node's global pose): at its
  // frozen pose once the submap is complete. Caller holds mu_.
  Pose2 InSubmapLocked(const Submap& s, const Pose2& anchor, int j) const;
  void WorkerLoop();
  int NodeAtOrBeforeLocked(std::uint64_t scan) const;
  // How far `to` is from `from` (EKF poses) in node spacings: the larger of travel / node_travel
  // and turn / node_turn. A scan one spacing or more from the newest node becomes a node.
  double NodeSpacings(const Pose2& from, const Pose2& to) const;

  const MappingOptions options_;
  mutable std::mutex mu_;
  std::condition_variable work_cv_;
  mutable std::condition_variable idle_cv_;
  std::vector<Node> nodes_;
  std::vector<Submap> submaps_;
  std::vector<GraphConstraint> constraints_;
  std::deque<int> queue_;   // nodes waiting for Process (threads = 1)
  bool busy_ = false;
  int processed_ = -1;  // the newest node Process has handled
  bool stop_ = false;
  int closures_since_optimize_ = 0;
  double tie_travel_ = -1.0;  // travel at the last accepted loop closure (-1: none yet)
  int tie_node_ = -1;          // node of the last accepted loop closure (-1: none yet)
  Pose2 dead_reckoning_;       // the odometry increments so far, integrated
  Eigen::Vector3d motion_variance_ = Eigen::Vector3d::Zero();  // since the newest node
  Pose2 last_local_;           // of the last scan (AddScan without odometry)
  // last_global_search_ before any (so that the first is due at once); a stored value below it
  // would overflow `index - last_global_search_`.
  static constexpr int kNoGlobalSearchYet = -1000000;
  int last_global_search_ = kNoGlobalSearchYet;  // node of the last global search
  int global_cursor_ = -1;     // submap searched globally last (they are searched in turn)
  // Global matches waiting for a second, agreeing match (MappingOptions::confirm_global_closures),
  // oldest first; at most 16 (a newer one replaces the oldest).
  struct PendingClosure {
    int submap = 0;
    GraphConstraint loop;  // from the submap's first node to the node matched
  };
  std::vector<PendingClosure> pending_closures_;
  // The prune_cell cells holding a point of a kept submap, at its poses when it was decided.
  std::unordered_set<std::int64_t> coverage_;
  ChainUncertainty chain_;     // of the processed nodes, in order
  EkfStepAgreement ekf_agreement_;  // the front end's (search_mu_), checkpointed
  bool ekf_shown_ = false;  // RedecideEarlierStepsLocked ran, checkpointed
  // Appends node `index` (processed, its chain constraint final, of 1 sigma `sigma`) to chain_.
  // Caller holds mu_.
  void AppendChainUncertaintyLocked(int index, const Eigen::Vector3d& sigma);
  // Where loop constraint `c` puts its newer node (c.to): c.from's graph pose and the match.
  Pose2 PlacedByLocked(const GraphConstraint& c) const;
  // The closures not optimised yet that move their node further from where the graph has it than
  // the smallest loop window, by index in constraints_, newest first. Caller holds mu_.
  std::vector<int> ClosuresThatMoveLocked() const;
  // Where the node `index` is searched from: the graph's pose, or where the newest of those puts
  // it (MappingOptions::search_where_closures_put). Caller holds mu_.
  Pose2 WhereClosuresPutLocked(int index) const;
  // Node `index`'s uncertainty relative to every submap through the chain and the closures
  // (closure_uncertainty.h; MappingOptions::window_through_ties). Caller holds mu_.
  std::vector<ChainUncertainty::Sigma> UncertaintyToSubmapsLocked(int index) const;
  // Nodes from `first` on are placed after their predecessor by the EKF's steps (they wait for
  // the thread). Caller holds mu_.
  void FollowPredecessorsLocked(int first);
  // Index in constraints_ of the chain constraint ending at node `index`, or -1. Caller holds mu_.
  int ChainConstraintLocked(int index) const;
  std::uint64_t revision_ = 0;
  MappingStats stats_;
  // Fixes the submap's frozen poses when node `index` is its last one. Caller holds mu_.
  void FreezeSubmapLocked(int index);
  // Pyramids of recently matched submaps, within kPyramidCacheBytes; guarded by search_mu_.
  static constexpr size_t kPyramidCacheBytes = 48u << 20;
  PyramidCache pyramid_cache_;
  // SeenMaskFor's, guarded by search_mu_: a few tens of kilobytes each, rebuilt in milliseconds.
  static constexpr size_t kSeenMasksKept = 64;
  std::unordered_map<int, std::shared_ptr<const SeenMask>> seen_masks_;
  mutable std::mutex search_mu_;  // one search / optimisation at a time (Serialize waits too)
  std::thread worker_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_MAPPING_BACKEND_H_

#include "server/laser_slam/mapping/mapping_backend.h"

#include <algorithm>
#include <cmath>

#include "server/common/stopwatch.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/chain_uncertainty.h"
#include "server/laser_slam/mapping/closure_uncertainty.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/loop_search.h"

namespace waymark::laser_slam {

MappingBackend::MappingBackend(const MappingOptions& options)
    : options_(options), pyramid_cache_(kPyramidCacheBytes) {
  if (options_.threads > 0) worker_ = std::thread([this] { WorkerLoop(); });
}

MappingBackend::~MappingBackend() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  work_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void MappingBackend::AddScan(std::uint64_t scan, double stamp, const Pose2& local,
                             const PointCloud& points) {
  ScanMotion motion;
  {
    std::lock_guard<std::mutex> lock(mu_);
    motion.increment = nodes_.empty() ? Pose2{} : Relative(last_local_, local);
    last_local_ = local;
  }
  AddScan(scan, stamp, local, points, motion);
}

void MappingBackend::AddScan(std::uint64_t scan, double stamp, const Pose2& local,
                             const PointCloud& points, const ScanMotion& motion) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    last_local_ = local;
    dead_reckoning_ = Compose(dead_reckoning_, motion.increment);
    motion_variance_ += motion.covariance.diagonal();
    if (!nodes_.empty() && NodeSpacings(nodes_.back().local, local) < 1.0) return;
  }
  // Only this thread appends nodes, so the decision above still holds.
  const PointCloud thinned = ThinPoints(points, options_.point_cell);
  int index = 0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    index = AppendNodeLocked(scan, stamp, local, thinned);
    if (options_.threads > 0) {
      queue_.push_back(index);
      work_cv_.notify_one();
      return;
    }
  }
  Process(index);
}

int MappingBackend::AppendNodeLocked(std::uint64_t scan, double stamp, const Pose2& local,
                                     const PointCloud& points) {
  Node node;
  node.scan = scan;
  node.stamp = stamp;
  node.local = local;
  node.global = local;
  node.points = std::make_shared<const PointCloud>(points);
  node.odometry = dead_reckoning_;
  node.odometry_variance = motion_variance_;
  motion_variance_.setZero();
  if (!nodes_.empty()) {
    const Node& prev = nodes_.back();
    const Pose2 step = Relative(prev.local, local);
    const double distance = std::hypot(step.x, step.y);
    node.travel = prev.travel + distance;
    node.global = Compose(prev.global, step);
    GraphConstraint chain;
    chain.kind = GraphConstraint::Kind::kChain;
    chain.from = static_cast<int>(nodes_.size()) - 1;
    chain.to = static_cast<int>(nodes_.size());
    chain.relative = step;
    const double sxy = options_.chain_sigma_xy + options_.chain_sigma_xy_per_m * distance;
    chain.sigma = Eigen::Vector3d(sxy, sxy,
                                  options_.chain_sigma_theta +
                                      options_.chain_sigma_theta_per_m * distance +
                                      options_.chain_sigma_theta_per_rad * std::abs(step.theta));
    constraints_.push_back(chain);
  }
  nodes_.push_back(std::move(node));
  const int index = static_cast<int>(nodes_.size()) - 1;
  if (submaps_.empty() || submaps_.back().complete) {
    submaps_.push_back(Submap{index, 0, false, {}});
  }
  Submap& submap = submaps_.back();
  ++submap.count;
  submap.complete = submap.count >= options_.submap_nodes;
  stats_.nodes = static_cast<int>(nodes_.size());
  stats_.submaps = static_cast<int>(submaps_.size());
  return index;
}

void MappingBackend::FreezeSubmapLocked(int index) {
  for (auto it = submaps_.rbegin(); it != submaps_.rend(); ++it) {
    if (index < it->first) continue;
    if (it->complete && it->frozen.empty() && index == it->first + it->count - 1) {
      const Pose2 anchor = nodes_[it->first].global;
      for (int j = it->first; j <= index; ++j) {
        it->frozen.push_back(Relative(anchor, nodes_[j].global));
      }
    }
    return;
  }
}

void MappingBackend::FollowPredecessorsLocked(int first) {
  // Nodes appended since (the thread is behind the stream) follow their predecessor.
  for (size_t j = static_cast<size_t>(std::max(first, 1)); j < nodes_.size(); ++j) {
    nodes_[j].global = Compose(nodes_[j - 1].global, Relative(nodes_[j - 1].local, nodes_[j].local));
  }
}

int MappingBackend::ChainConstraintLocked(int index) const {
  // The newest chain constraint ending at the node: loop constraints to it come later, from its
  // own Process, so this is a short walk from the end.
  for (int c = static_cast<int>(constraints_.size()) - 1; c >= 0; --c) {
    if (constraints_[c].kind == GraphConstraint::Kind::kChain && constraints_[c].to == index) {
      return c;
    }
  }
  return -1;
}

void MappingBackend::AppendChainUncertaintyLocked(int index, const Eigen::Vector3d& sigma) {
  const Pose2& local = nodes_[index].local;
  nodes_[index].chain_sigma = sigma;
  chain_.Append(Eigen::Vector2d(local.x, local.y), sigma);
}

// Global matches held at once for confirmation: a bound, not a tuning (a search holds at most
// max_candidates, and each waits confirm_within_nodes nodes at most).
constexpr size_t kMaxPendingClosures = 16;

std::vector<ChainUncertainty::Sigma> MappingBackend::UncertaintyToSubmapsLocked(int index) const {
  std::vector<SubmapSpan> spans;
  spans.reserve(submaps_.size());
  for (const Submap& m : submaps_) spans.push_back({m.first, m.first + m.count - 1});
  // With windows_wait_for_closures_that_move, a closure the graph has not taken yet that moves its
  // node beyond the smallest window ties nothing until the graph holds it.
  std::vector<bool> waiting(constraints_.size(), false);
  if (options_.windows_wait_for_closures_that_move) {
    for (int k : ClosuresThatMoveLocked()) waiting[k] = true;
  }
  std::vector<ClosureTie> closures;
  for (size_t k = 0; k < constraints_.size(); ++k) {
    const GraphConstraint& c = constraints_[k];
    if (c.kind != GraphConstraint::Kind::kLoop || !c.enabled || waiting[k]) continue;
    const auto x = std::lower_bound(submaps_.begin(), submaps_.end(), c.from,
                                    [](const Submap& m, int f) { return m.first < f; });
    if (x == submaps_.end() || x->first != c.from) continue;
    closures.push_back({static_cast<int>(x - submaps_.begin()), c.to, c.sigma});
  }
  return UncertaintyToSubmaps(chain_, spans, closures, index);
}

void MappingBackend::Process(int index) {
  std::lock_guard<std::mutex> one_at_a_time(search_mu_);
  if (options_.local_matching && index > 0) MatchLocalMap(index);
  {
    std::lock_guard<std::mutex> lock(mu_);
    const int chain = ChainConstraintLocked(index);
    AppendChainUncertaintyLocked(
        index, chain >= 0 ? constraints_[chain].sigma : Eigen::Vector3d::Zero().eval());
    FreezeSubmapLocked(index);
  }
  if (index % options_.search_every_nodes == 0) SearchLoops(index);
  bool due = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    due = closures_since_optimize_ >= options_.optimize_every_closures;
  }
  if (due) Optimize(index);
  std::lock_guard<std::mutex> lock(mu_);
  if (options_.prune_redundant_submaps) DecidePruningLocked(index);
  processed_ = index;
}

Pose2 MappingBackend::PlacedByLocked(const GraphConstraint& c) const {
  return Compose(nodes_[c.from].global, c.relative);
}

std::vector<int> MappingBackend::ClosuresThatMoveLocked() const {
  std::vector<int> moving;
  // The closures not optimised yet are the newest loop constraints (appended in order).
  int left = closures_since_optimize_;
  for (int k = static_cast<int>(constraints_.size()) - 1; k >= 0 && left > 0; --k) {
    const GraphConstraint& c = constraints_[k];
    if (c.kind != GraphConstraint::Kind::kLoop) continue;
    --left;
    const Pose2 moved = Relative(nodes_[c.to].global, PlacedByLocked(c));
    if (c.enabled && (std::hypot(moved.x, moved.y) > options_.loop_window_min_xy ||
                      std::abs(moved.theta) > options_.loop_window_min_theta)) {
      moving.push_back(k);
    }
  }
  return moving;
}

Pose2 MappingBackend::WhereClosuresPutLocked(int index) const {
  const Pose2& node = nodes_[index].global;
  if (!options_.search_where_closures_put) return node;
  const std::vector<int> moving = ClosuresThatMoveLocked();
  if (moving.empty()) return node;
  const GraphConstraint& c = constraints_[moving.front()];  // the newest
  return Compose(PlacedByLocked(c), Relative(nodes_[c.to].global, node));
}

void MappingBackend::SearchLoops(int index) {
  const auto start = Clock::now();
  struct Candidate {
    int submap = 0;
    double distance = 0.0;
    Pose2 initial;  // the node in the submap's frame, as the graph has it now
    SearchWindow window;
    bool global = false;  // the whole submap at every heading
    int first = 0;        // the submap's first node
    int confirms = -1;    // the pending global match it would confirm (index), or -1
  };
  std::vector<Candidate> candidates;
  PointCloud query;
  {
    std::lock_guard<std::mutex> lock(mu_);
    const Node& node = nodes_[index];
    // The nodes placed by the graph (local matching made them agree with each other), not by
    // the EKF, whose steps can be far off where it associated wrongly.
    for (int j = std::max(0, index - options_.query_nodes + 1); j <= index; ++j) {
      AppendTransformed(*nodes_[j].points, Relative(node.global, nodes_[j].global), &query);
    }
    const Pose2 here = WhereClosuresPutLocked(index);
    const bool global_due = index - last_global_search_ >= options_.global_search_every_nodes;
    std::vector<ChainUncertainty::Sigma> through;
    if (options_.window_through_ties) through = UncertaintyToSubmapsLocked(index);
    std::vector<Candidate> global;
    for (int s = 0; s < static_cast<int>(submaps_.size()); ++s) {
      const Submap& submap = submaps_[s];
      if (!submap.complete || submap.pruned) continue;
      const int last = submap.first + submap.count - 1;
      if (node.travel - nodes_[last].travel < options_.min_loop_travel) continue;
      // Tied to the submap by the chain since it ended or through the closures
      // (closure_uncertainty.h); without window_through_ties, by the chain since it ended or
      // since the newest closure, whichever is newer.
      const ChainUncertainty::Sigma sigma = options_.window_through_ties
                                                ? through[s]
                                                : chain_.Between(std::max(last, tie_node_), index);
      Candidate c;
      c.submap = s;
      c.first = submap.first;
      c.initial = Relative(nodes_[submap.first].global, here);
      c.window.xy = std::max(options_.loop_window_min_xy, options_.loop_window_sigmas * sigma.xy);
      c.window.theta = std::min(
          M_PI, std::max(options_.loop_window_min_theta, options_.loop_window_sigmas * sigma.theta));
      c.distance = 1e300;
      for (int j = submap.first; j <= last; ++j) {
        c.distance = std::min(c.distance, std::hypot(nodes_[j].global.x - here.x,
                                                     nodes_[j].global.y - here.y));
      }
      // A submap further than the window reaches cannot hold the robot, wherever within its
      // 3 sigma the graph is wrong; a global search looks at the whole of a submap the window
      // reaches (the window outgrew it), and at no other.
      const bool reachable = c.distance <= options_.candidate_distance + c.window.xy;
      if (c.window.xy > options_.max_window_xy) {
        c.global = true;
        if (global_due && (reachable || !options_.global_within_window)) global.push_back(c);
        continue;
      }
      if (!reachable) continue;
      candidates.push_back(c);
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
    if (static_cast<int>(candidates.size()) > options_.max_candidates) {
      candidates.resize(options_.max_candidates);
    }
    if (!global.empty()) {
      // Submaps in turn, from the one after the last searched globally.
      std::stable_partition(global.begin(), global.end(),
                            [&](const Candidate& c) { return c.submap > global_cursor_; });
      if (static_cast<int>(global.size()) > options_.max_candidates) {
        global.resize(options_.max_candidates);
      }
      global_cursor_ = global.back().submap;
      last_global_search_ = index;
      ++stats_.global_searches;
      candidates.insert(candidates.end(), global.begin(), global.end());
    }
    // Pending global matches (confirm_global_closures): dropped when too old, otherwise matched
    // again from this node, in a window around where the match and the chain since put it.
    const auto expired = [&](const PendingClosure& p) {
      return index - p.loop.to > options_.confirm_within_nodes;
    };
    stats_.closures_unconfirmed += static_cast<int>(
        std::count_if(pending_closures_.begin(), pending_closures_.end(), expired));
    pending_closures_.erase(
        std::remove_if(pending_closures_.begin(), pending_closures_.end(), expired),
        pending_closures_.end());
    for (size_t k = 0; k < pending_closures_.size(); ++k) {
      const PendingClosure& p = pending_closures_[k];
      if (index - p.loop.to < options_.query_nodes) continue;  // would share scans with it
      const ChainUncertainty::Sigma sigma = chain_.Between(p.loop.to, index);
      Candidate c;
      c.submap = p.submap;
      c.first = p.loop.from;
      c.initial = Compose(p.loop.relative, Relative(nodes_[p.loop.to].global, node.global));
      c.window.xy = std::max(options_.loop_window_min_xy, options_.loop_window_sigmas * sigma.xy);
      c.window.theta = std::min(
          M_PI, std::max(options_.loop_window_min_theta, options_.loop_window_sigmas * sigma.theta));
      c.confirms = static_cast<int>(k);
      candidates.push_back(c);
    }
  }
  const LoopQuery loop_query = MakeLoopQuery(query, options_);
  int accepted = 0, rejected = 0, ambiguous = 0, slid = 0, where_seen = 0;
  std::vector<GraphConstraint> found;  // matches that passed their own tests
  std::vector<int> found_confirms;     // per found match: the pending match it confirms, or -1
  std::vector<PendingClosure> held;    // global matches to confirm (confirm_global_closures)
  for (const Candidate& c : candidates) {
    SubmapGrids grids;
    grids.fine = [&] { return PyramidFor(c.submap, 1); };
    grids.coarse = [&] { return PyramidFor(c.submap, options_.coarse_search_factor); };
    grids.fine_frame = [&] { return FineFrameOf(c.submap); };
    grids.seen = [&] { return SeenMaskFor(c.submap); };
    const LoopMatch match =
        MatchSubmap(loop_query, grids, c.initial, c.window, c.global, options_);
    if (match.verdict == LoopMatch::Verdict::kRejected) {
      ++rejected;
      continue;
    }
    if (match.verdict == LoopMatch::Verdict::kAmbiguous) {
      ++ambiguous;
      continue;
    }
    if (match.loosened) ++slid;
    if (match.where_seen) ++where_seen;
    GraphConstraint loop;
    loop.kind = GraphConstraint::Kind::kLoop;
    loop.from = c.first;
    loop.to = index;
    loop.relative = match.pose;
    loop.sigma = match.sigma;
    loop.score = match.score;
    if (c.global && options_.confirm_global_closures) {
      held.push_back({c.submap, loop});
      continue;
    }
    found.push_back(loop);
    found_confirms.push_back(c.confirms);
  }
  std::lock_guard<std::mutex> lock(mu_);
  // Matches in different submaps that put the node in places further apart than rival_far are
  // rival hypotheses too (two look-alike rooms, each in its own submap): none is kept.
  bool conflict = false;
  for (size_t i = 0; i < found.size() && options_.rival_ratio > 0.0; ++i) {
    for (size_t j = 0; j < i; ++j) {
      const Pose2 a = PlacedByLocked(found[i]), b = PlacedByLocked(found[j]);
      conflict = conflict || std::hypot(a.x - b.x, a.y - b.y) > options_.rival_far;
    }
  }
  if (conflict) {
    ambiguous += static_cast<int>(found.size());
    found.clear();
    held.clear();
  }
  std::vector<bool> confirmed(pending_closures_.size(), false);
  for (size_t i = 0; i < found.size(); ++i) {
    const int k = found_confirms[i];
    if (k >= 0 && !confirmed[k]) {
      // The global match it confirms enters the graph with it.
      confirmed[k] = true;
      ++accepted;
      constraints_.push_back(pending_closures_[k].loop);
      ++closures_since_optimize_;
    }
    ++accepted;
    constraints_.push_back(found[i]);
    ++closures_since_optimize_;
    tie_travel_ = nodes_[index].travel;
    tie_node_ = index;
  }
  for (size_t k = confirmed.size(); k-- > 0;) {
    if (confirmed[k]) pending_closures_.erase(pending_closures_.begin() + static_cast<long>(k));
  }
  for (PendingClosure& p : held) {
    ++stats_.closures_pending;
    if (pending_closures_.size() >= kMaxPendingClosures) {
      pending_closures_.erase(pending_closures_.begin());
    }
    pending_closures_.push_back(std::move(p));
  }
  ++stats_.searches;
  stats_.candidates += static_cast<int>(candidates.size());
  stats_.closures_accepted += accepted;
  stats_.closures_rejected += rejected;
  stats_.closures_ambiguous += ambiguous;
  stats_.closures_loosened += slid;
  stats_.closures_where_seen += where_seen;
  stats_.search_ms.push_back(MsSince(start));
}

Pose2 MappingBackend::InSubmapLocked(const Submap& s, const Pose2& anchor, int j) const {
  return s.frozen.empty() ? Relative(anchor, nodes_[j].global) : s.frozen[j - s.first];
}

PointCloud MappingBackend::SubmapCloud(int submap) const {
  PointCloud cloud;
  std::lock_guard<std::mutex> lock(mu_);
  const Submap& s = submaps_[submap];
  const Pose2 anchor = nodes_[s.first].global;
  for (int j = s.first; j < s.first + s.count; ++j) {
    AppendTransformed(*nodes_[j].points, InSubmapLocked(s, anchor, j), &cloud);
  }
  return cloud;
}

std::shared_ptr<const SearchPyramid> MappingBackend::PyramidFor(int submap, int coarsening) {
  if (std::shared_ptr<const SearchPyramid> cached = pyramid_cache_.Find(submap, coarsening)) {
    return cached;
  }
  const PointCloud thinned = ThinPoints(SubmapCloud(submap), coarsening * options_.point_cell);
  const double resolution = coarsening * options_.grid_resolution;
  const double sigma = coarsening * options_.grid_sigma;
  if (coarsening == 1) {
    pyramid_cache_.SetFrame(submap, GridFrameOf(thinned, resolution, sigma));
  }
  auto pyramid = std::make_shared<const SearchPyramid>(
      BuildLikelihoodGrid(thinned, resolution, sigma), options_.search_depth);
  pyramid_cache_.Insert(submap, coarsening, pyramid);
  return pyramid;
}

std::shared_ptr<const SeenMask> MappingBackend::SeenMaskFor(int submap) {
  if (const auto it = seen_masks_.find(submap); it != seen_masks_.end()) return it->second;
  std::vector<SeenScan> scans;
  std::vector<std::shared_ptr<const PointCloud>> held;  // the scans' points, while they are read
  {
    std::lock_guard<std::mutex> lock(mu_);
    const Submap& s = submaps_[submap];
    const Pose2 anchor = nodes_[s.first].global;
    for (int j = s.first; j < s.first + s.count; ++j) {
      if (!nodes_[j].points) continue;
      held.push_back(nodes_[j].points);
      scans.push_back({InSubmapLocked(s, anchor, j), held.back().get()});
    }
  }
  auto mask = std::make_shared<const SeenMask>(BuildSeenMask(scans, 4 * options_.grid_resolution));
  if (seen_masks_.size() >= kSeenMasksKept) seen_masks_.clear();
  seen_masks_[submap] = mask;
  return mask;
}

GridFrame MappingBackend::FineFrameOf(int submap) {
  if (const std::optional<GridFrame> frame = pyramid_cache_.Frame(submap)) return *frame;
  const GridFrame frame = GridFrameOf(ThinPoints(SubmapCloud(submap), options_.point_cell),
                                      options_.grid_resolution, options_.grid_sigma);
  pyramid_cache_.SetFrame(submap, frame);
  return frame;
}

void MappingBackend::Optimize(int upto) {
  const auto start = Clock::now();
  std::vector<Pose2> poses;
  std::vector<GraphConstraint> constraints;
  std::vector<int> indices;  // of the copied constraints in constraints_
  {
    // The graph of the nodes handled so far: nodes appended since (the thread is behind the
    // stream) only follow their predecessor, so leaving them out changes nothing but makes the
    // result independent of how far behind the thread is (a replay gives the same map however
    // fast it is sent).
    std::lock_guard<std::mutex> lock(mu_);
    poses.reserve(upto + 1);
    for (int i = 0; i <= upto; ++i) poses.push_back(nodes_[i].global);
    for (int i = 0; i < static_cast<int>(constraints_.size()); ++i) {
      if (constraints_[i].from <= upto && constraints_[i].to <= upto) indices.push_back(i);
    }
    // In the order the inline back end would have added them (by newer node, chain first): the
    // thread may have appended a chain constraint before a loop one that belongs earlier, and the
    // order of residuals changes the solver's rounding.
    std::stable_sort(indices.begin(), indices.end(), [&](int a, int b) {
      const GraphConstraint& ca = constraints_[a];
      const GraphConstraint& cb = constraints_[b];
      return std::make_pair(ca.to, ca.kind) < std::make_pair(cb.to, cb.kind);
    });
    for (int i : indices) constraints.push_back(constraints_[i]);
    closures_since_optimize_ = 0;
  }
  GraphSolveOptions solve;
  solve.huber_scale = options_.huber_scale;
  solve.max_iterations = options_.max_iterations;
  const int switched_off =
      SolveRejectingOutliers(poses, constraints, solve, options_.outlier_residual);
  std::lock_guard<std::mutex> lock(mu_);
  const size_t solved = poses.size();
  for (size_t i = 0; i < solved; ++i) nodes_[i].global = poses[i];
  // Pruned nodes are out of the graph: they move with their kept anchor.
  for (size_t i = 0; i < solved; ++i) {
    Node& n = nodes_[i];
    if (n.pruned) n.global = PrunedPoseLocked(n);
  }
  FollowPredecessorsLocked(static_cast<int>(solved));
  for (size_t i = 0; i < constraints.size(); ++i) {
    constraints_[indices[i]].enabled = constraints[i].enabled;
  }
  ++revision_;
  ++stats_.optimizations;
  stats_.closures_switched_off += switched_off;
  stats_.optimize_ms.push_back(MsSince(start));
}

void MappingBackend::WorkerLoop() {
  for (;;) {
    int index = 0;
    {
      std::unique_lock<std::mutex> lock(mu_);
      work_cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      index = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    Process(index);
    {
      std::lock_guard<std::mutex> lock(mu_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void MappingBackend::WaitForPending() const {
  if (options_.threads == 0) return;
  std::unique_lock<std::mutex> lock(mu_);
  idle_cv_.wait(lock, [&] { return stop_ || (queue_.empty() && !busy_); });
}

void MappingBackend::Flush() {
  WaitForPending();
  std::lock_guard<std::mutex> one_at_a_time(search_mu_);
  bool due = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    due = closures_since_optimize_ > 0 && processed_ >= 0;
  }
  if (due) Optimize(processed_);
}

double MappingBackend::NodeSpacings(const Pose2& from, const Pose2& to) const {
  const Pose2 d = Relative(from, to);
  return std::max(std::hypot(d.x, d.y) / options_.node_travel,
                  std::abs(d.theta) / options_.node_turn);
}

int MappingBackend::NodeAtOrBeforeLocked(std::uint64_t scan) const {
  const auto it = std::upper_bound(nodes_.begin(), nodes_.end(), scan,
                                   [](std::uint64_t s, const Node& n) { return s < n.scan; });
  return static_cast<int>(it - nodes_.begin()) - 1;
}

Pose2 MappingBackend::CorrectionAt(std::uint64_t scan, const Pose2& robot) const {
  std::lock_guard<std::mutex> lock(mu_);
  const int i = NodeAtOrBeforeLocked(scan);
  if (i < 0) return Pose2{};
  const Node& a = nodes_[i];
  const Pose2 before = Compose(a.global, Invert(a.local));
  if (!options_.interpolate_corrections || a.scan == scan ||
      i + 1 >= static_cast<int>(nodes_.size())) {
    return before;
  }
  // The correction changes from node to node by what local matching and the graph found the
  // EKF's steps in between to be off (a turn the EKF made a degree short, say): the scans in
  // between took that change a piece at a time, measured as nodes are spaced, not all at the
  // next node.
  const Node& b = nodes_[i + 1];
  const double whole = NodeSpacings(a.local, b.local);
  if (!(whole > 0.0)) return before;
  const double w = std::clamp(NodeSpacings(a.local, robot) / whole, 0.0, 1.0);
  const Pose2 change = Relative(before, Compose(b.global, Invert(b.local)));
  return Compose(before, Pose2{w * change.x, w * change.y, w * NormalizeAngle(change.theta)});
}

Pose2 MappingBackend::ToGlobal(std::uint64_t scan, const Pose2& local) const {
  return Compose(CorrectionAt(scan, local), local);
}

std::vector<NodeView> MappingBackend::Nodes() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<NodeView> out;
  out.reserve(nodes_.size());
  for (const Node& n : nodes_) {
    out.push_back(NodeView{n.scan, n.stamp, n.global, n.points, n.chain_sigma});
  }
  return out;
}

std::vector<GraphConstraint> MappingBackend::Constraints() const {
  std::lock_guard<std::mutex> lock(mu_);
  return constraints_;
}

MappingStats MappingBackend::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  MappingStats s = stats_;
  s.graph_nodes = stats_.nodes - stats_.nodes_pruned;
  s.pending_nodes = static_cast<int>(queue_.size()) + (busy_ ? 1 : 0);
  return s;
}

int MappingBackend::loop_closures() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_.closures_accepted - stats_.closures_switched_off;
}

std::uint64_t MappingBackend::revision() const {
  std::lock_guard<std::mutex> lock(mu_);
  return revision_;
}

}  // namespace waymark::laser_slam

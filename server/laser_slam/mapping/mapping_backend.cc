#include "server/laser_slam/mapping/mapping_backend.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/common/binary_io.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/input_bounds.h"
#include "server/laser_slam/mapping/correlative_matcher.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kMagic = 0x5047574d;  // "MWGP"
// 2: the newest node Process handled, so that nodes still waiting for the back end's thread are
// processed after a resume (version 1 counted them as processed: their loop searches were lost,
// and a session resumed from a checkpoint ended 0.3 m away from the uninterrupted one on Intel).
constexpr std::uint32_t kVersion = 2;
// Submap pyramids kept between searches (a few MB each).
constexpr size_t kPyramidCacheSize = 12;

}  // namespace

MappingBackend::MappingBackend(const MappingOptions& options) : options_(options) {
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
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!nodes_.empty()) {
      const Pose2 moved = Relative(nodes_.back().local, local);
      if (std::hypot(moved.x, moved.y) < options_.node_travel &&
          std::abs(moved.theta) < options_.node_turn) {
        return;
      }
    }
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

void MappingBackend::Process(int index) {
  std::lock_guard<std::mutex> one_at_a_time(search_mu_);
  {
    std::lock_guard<std::mutex> lock(mu_);
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
  processed_ = index;
}

void MappingBackend::SearchLoops(int index) {
  const auto start = Clock::now();
  struct Candidate {
    int submap = 0;
    double distance = 0.0;
    Pose2 initial;  // the node in the submap's frame, as the graph has it now
    SearchWindow window;
  };
  std::vector<Candidate> candidates;
  PointCloud query;
  double node_travel = 0.0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    const Node& node = nodes_[index];
    node_travel = node.travel;
    for (int j = std::max(0, index - options_.query_nodes + 1); j <= index; ++j) {
      AppendTransformed(*nodes_[j].points, Relative(node.local, nodes_[j].local), &query);
    }
    for (int s = 0; s < static_cast<int>(submaps_.size()); ++s) {
      const Submap& submap = submaps_[s];
      if (!submap.complete) continue;
      const Node& last = nodes_[submap.first + submap.count - 1];
      const double gap = node.travel - last.travel;
      if (gap < options_.min_loop_travel) continue;
      const double untied = tie_travel_ >= 0.0 ? std::min(gap, node.travel - tie_travel_) : gap;
      Candidate c;
      c.submap = s;
      c.window.xy = std::min(3.0 * (options_.window_base_xy + options_.drift_xy_per_m * untied),
                             options_.max_window_xy);
      c.window.theta =
          std::min(3.0 * (options_.window_base_theta + options_.drift_theta_per_m * untied),
                   options_.max_window_theta);
      c.distance = 1e300;
      for (int j = submap.first; j < submap.first + submap.count; ++j) {
        c.distance = std::min(c.distance, std::hypot(nodes_[j].global.x - node.global.x,
                                                     nodes_[j].global.y - node.global.y));
      }
      if (c.distance > options_.candidate_distance + c.window.xy) continue;
      c.initial = Relative(nodes_[submap.first].global, node.global);
      candidates.push_back(c);
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
  if (static_cast<int>(candidates.size()) > options_.max_candidates) {
    candidates.resize(options_.max_candidates);
  }
  query = ThinPoints(query, options_.point_cell);
  int accepted = 0, rejected = 0;
  // The wide search scores half the points (one per 10 cm): the branch and bound costs in
  // proportion to them, and a wall sampled every 10 cm still pins the pose to the 5 cm grid. The
  // best pose is then refined and scored with all of them in a window of two cells.
  const PointCloud sparse = ThinPoints(query, 2.0 * options_.point_cell);
  for (const Candidate& c : candidates) {
    const std::shared_ptr<const SearchPyramid> pyramid = PyramidFor(c.submap);
    std::optional<GridMatch> match =
        MatchInWindow(*pyramid, sparse, c.initial, c.window, options_.min_score);
    if (match) {
      const SearchWindow refine{2.0 * options_.grid_resolution, 0.02};
      match = MatchInWindow(*pyramid, query, match->pose, refine, options_.min_score);
    }
    if (!match || match->score < options_.min_score) {
      ++rejected;
      continue;
    }
    ++accepted;
    std::lock_guard<std::mutex> lock(mu_);
    GraphConstraint loop;
    loop.kind = GraphConstraint::Kind::kLoop;
    loop.from = submaps_[c.submap].first;
    loop.to = index;
    loop.relative = match->pose;
    loop.sigma = Eigen::Vector3d(options_.loop_sigma_xy, options_.loop_sigma_xy,
                                 options_.loop_sigma_theta);
    loop.score = match->score;
    constraints_.push_back(loop);
    ++closures_since_optimize_;
    tie_travel_ = node_travel;
  }
  std::lock_guard<std::mutex> lock(mu_);
  ++stats_.searches;
  stats_.candidates += static_cast<int>(candidates.size());
  stats_.closures_accepted += accepted;
  stats_.closures_rejected += rejected;
  stats_.search_ms.push_back(MsSince(start));
}

std::shared_ptr<const SearchPyramid> MappingBackend::PyramidFor(int submap) {
  PointCloud cloud;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto it = pyramid_cache_.begin(); it != pyramid_cache_.end(); ++it) {
      if (it->first == submap) {
        auto entry = *it;
        pyramid_cache_.erase(it);
        pyramid_cache_.push_back(entry);
        return entry.second;
      }
    }
    const Submap& s = submaps_[submap];
    const Pose2 anchor = nodes_[s.first].global;
    for (int j = s.first; j < s.first + s.count; ++j) {
      const Pose2 pose = s.frozen.empty() ? Relative(anchor, nodes_[j].global)
                                          : s.frozen[j - s.first];
      AppendTransformed(*nodes_[j].points, pose, &cloud);
    }
  }
  auto pyramid = std::make_shared<const SearchPyramid>(
      BuildLikelihoodGrid(ThinPoints(cloud, options_.point_cell), options_.grid_resolution,
                          options_.grid_sigma),
      options_.search_depth);
  std::lock_guard<std::mutex> lock(mu_);
  pyramid_cache_.emplace_back(submap, pyramid);
  if (pyramid_cache_.size() > kPyramidCacheSize) pyramid_cache_.pop_front();
  return pyramid;
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
  for (size_t i = solved; i < nodes_.size(); ++i) {
    nodes_[i].global =
        Compose(nodes_[i - 1].global, Relative(nodes_[i - 1].local, nodes_[i].local));
  }
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

void MappingBackend::Flush() {
  if (options_.threads > 0) {
    std::unique_lock<std::mutex> lock(mu_);
    idle_cv_.wait(lock, [&] { return stop_ || (queue_.empty() && !busy_); });
  }
  std::lock_guard<std::mutex> one_at_a_time(search_mu_);
  bool due = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    due = closures_since_optimize_ > 0 && processed_ >= 0;
  }
  if (due) Optimize(processed_);
}

int MappingBackend::NodeAtOrBeforeLocked(std::uint64_t scan) const {
  const auto it = std::upper_bound(nodes_.begin(), nodes_.end(), scan,
                                   [](std::uint64_t s, const Node& n) { return s < n.scan; });
  return static_cast<int>(it - nodes_.begin()) - 1;
}

Pose2 MappingBackend::CorrectionAt(std::uint64_t scan) const {
  std::lock_guard<std::mutex> lock(mu_);
  const int i = NodeAtOrBeforeLocked(scan);
  if (i < 0) return Pose2{};
  return Compose(nodes_[i].global, Invert(nodes_[i].local));
}

Pose2 MappingBackend::ToGlobal(std::uint64_t scan, const Pose2& local) const {
  return Compose(CorrectionAt(scan), local);
}

std::vector<NodeView> MappingBackend::Nodes() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<NodeView> out;
  out.reserve(nodes_.size());
  for (const Node& n : nodes_) out.push_back(NodeView{n.scan, n.stamp, n.global, n.points});
  return out;
}

std::vector<GraphConstraint> MappingBackend::Constraints() const {
  std::lock_guard<std::mutex> lock(mu_);
  return constraints_;
}

MappingStats MappingBackend::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  MappingStats s = stats_;
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

namespace {

void PutPose(BinaryWriter& w, const Pose2& p) {
  w.Put(p.x);
  w.Put(p.y);
  w.Put(p.theta);
}

// A stored pose, within the bounds of a map (input_bounds.h).
bool GetPose(BinaryReader& r, Pose2* p) {
  return r.Get(&p->x) && r.Get(&p->y) && r.Get(&p->theta) && PlausibleMapPose(*p);
}

}  // namespace

std::string MappingBackend::Serialize() const {
  // Between two nodes' processing: a node half processed (a loop constraint added, its
  // optimisation not yet run) could not be told from a finished one.
  std::lock_guard<std::mutex> one_at_a_time(search_mu_);
  std::lock_guard<std::mutex> lock(mu_);
  BinaryWriter w;
  w.Put(kMagic);
  w.Put(kVersion);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(nodes_.size()));
  for (const Node& n : nodes_) {
    w.Put(n.scan);
    w.Put(n.stamp);
    w.Put(n.travel);
    PutPose(w, n.local);
    PutPose(w, n.global);
    w.Put<std::uint32_t>(static_cast<std::uint32_t>(n.points->size()));
    for (const Eigen::Vector2f& p : *n.points) {
      w.Put(p.x());
      w.Put(p.y());
    }
  }
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(submaps_.size()));
  for (const Submap& s : submaps_) {
    w.Put<std::int32_t>(s.first);
    w.Put<std::int32_t>(s.count);
    w.Put<std::uint8_t>(s.complete);
    w.Put<std::uint32_t>(static_cast<std::uint32_t>(s.frozen.size()));
    for (const Pose2& p : s.frozen) PutPose(w, p);
  }
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(constraints_.size()));
  for (const GraphConstraint& c : constraints_) {
    w.Put<std::uint8_t>(static_cast<std::uint8_t>(c.kind));
    w.Put<std::int32_t>(c.from);
    w.Put<std::int32_t>(c.to);
    PutPose(w, c.relative);
    for (int i = 0; i < 3; ++i) w.Put(c.sigma(i));
    w.Put<std::uint8_t>(c.enabled);
    w.Put(c.score);
  }
  w.Put(tie_travel_);
  w.Put<std::int32_t>(closures_since_optimize_);
  w.Put(revision_);
  w.Put<std::int32_t>(processed_);
  for (int v : {stats_.searches, stats_.candidates, stats_.closures_accepted,
                stats_.closures_rejected, stats_.closures_switched_off, stats_.optimizations}) {
    w.Put<std::int32_t>(v);
  }
  return w.Take();
}

absl::StatusOr<std::unique_ptr<MappingBackend>> MappingBackend::Deserialize(
    const MappingOptions& options, absl::string_view bytes) {
  const auto corrupt = [](const char* what) {
    return absl::DataLossError(absl::StrCat("laser SLAM pose graph checkpoint is corrupt: ", what));
  };
  BinaryReader r(bytes);
  std::uint32_t magic = 0, version = 0, count = 0;
  if (!r.Get(&magic) || magic != kMagic) return corrupt("not a pose graph");
  if (!r.Get(&version) || version < 1 || version > kVersion) {
    return absl::FailedPreconditionError(absl::StrCat(
        "pose graph checkpoint version ", version, " is not supported (expected ", kVersion, ")"));
  }
  auto backend = std::make_unique<MappingBackend>(options);
  MappingBackend& b = *backend;
  // Every count is checked against the bytes left before anything is allocated for it: a
  // 226-byte checkpoint claiming 10^8 constraints allocated 8 GB (found by make fuzz). The least
  // a stored element takes, in bytes:
  constexpr size_t kPose = 3 * sizeof(double);
  constexpr size_t kNode = sizeof(std::uint64_t) + 2 * sizeof(double) + 2 * kPose + 4;
  constexpr size_t kSubmap = 4 + 4 + 1 + 4;
  constexpr size_t kConstraint = 1 + 4 + 4 + kPose + 3 * sizeof(double) + 1 + sizeof(double);
  if (!r.Get(&count) || count > 10000000 || count > r.remaining() / kNode) {
    return corrupt("node count");
  }
  b.nodes_.resize(count);
  std::uint64_t previous_scan = 0;
  for (Node& n : b.nodes_) {
    std::uint32_t points = 0;
    if (!r.Get(&n.scan) || !r.Get(&n.stamp) || !r.Get(&n.travel) || !GetPose(r, &n.local) ||
        !GetPose(r, &n.global) || !r.Get(&points) || points > 100000 ||
        points > r.remaining() / (2 * sizeof(float)) || n.scan <= previous_scan) {
      return corrupt("node");
    }
    previous_scan = n.scan;
    PointCloud cloud(points);
    for (Eigen::Vector2f& p : cloud) {
      float x = 0, y = 0;
      if (!r.Get(&x) || !r.Get(&y) || !PlausibleRobotPoint(x, y)) {
        return corrupt("node points");
      }
      p = Eigen::Vector2f(x, y);
    }
    n.points = std::make_shared<const PointCloud>(std::move(cloud));
  }
  const int nodes = static_cast<int>(count);
  if (!r.Get(&count) || count > b.nodes_.size() || count > r.remaining() / kSubmap) {
    return corrupt("submap count");
  }
  b.submaps_.resize(count);
  for (Submap& s : b.submaps_) {
    std::uint8_t complete = 0;
    std::uint32_t frozen = 0;
    if (!r.Get(&s.first) || !r.Get(&s.count) || !r.Get(&complete) || s.first < 0 || s.count < 1 ||
        s.first + s.count > nodes || !r.Get(&frozen) ||
        (frozen != 0 && frozen != static_cast<std::uint32_t>(s.count)) ||
        frozen > r.remaining() / kPose) {
      return corrupt("submap");
    }
    s.complete = complete != 0;
    s.frozen.resize(frozen);
    for (Pose2& p : s.frozen) {
      if (!GetPose(r, &p)) return corrupt("submap pose");
    }
  }
  if (!r.Get(&count) || count > 100000000 || count > r.remaining() / kConstraint) {
    return corrupt("constraint count");
  }
  b.constraints_.resize(count);
  for (GraphConstraint& c : b.constraints_) {
    std::uint8_t kind = 0, enabled = 0;
    if (!r.Get(&kind) || kind > 1 || !r.Get(&c.from) || !r.Get(&c.to) || c.from < 0 ||
        c.to < 0 || c.from >= nodes || c.to >= nodes || !GetPose(r, &c.relative)) {
      return corrupt("constraint");
    }
    for (int i = 0; i < 3; ++i) {
      if (!r.Get(&c.sigma(i)) || !(c.sigma(i) > 0.0) || !std::isfinite(c.sigma(i))) {
        return corrupt("constraint sigma");
      }
    }
    if (!r.Get(&enabled) || !r.Get(&c.score)) return corrupt("constraint");
    c.kind = static_cast<GraphConstraint::Kind>(kind);
    c.enabled = enabled != 0;
  }
  if (!r.Get(&b.tie_travel_) || !r.Get(&b.closures_since_optimize_) || !r.Get(&b.revision_)) {
    return corrupt("counters");
  }
  std::int32_t processed = static_cast<std::int32_t>(b.nodes_.size()) - 1;
  if (version >= 2 && (!r.Get(&processed) || processed < -1 ||
                       processed >= static_cast<std::int32_t>(b.nodes_.size()))) {
    return corrupt("processed node");
  }
  for (int* v : {&b.stats_.searches, &b.stats_.candidates, &b.stats_.closures_accepted,
                 &b.stats_.closures_rejected, &b.stats_.closures_switched_off,
                 &b.stats_.optimizations}) {
    std::int32_t value = 0;
    if (!r.Get(&value)) return corrupt("counters");
    *v = value;
  }
  if (!r.done()) return corrupt("trailing bytes");
  b.stats_.nodes = nodes;
  b.processed_ = processed;
  b.stats_.submaps = static_cast<int>(b.submaps_.size());
  // Nodes that were waiting for the thread are handled now, in order, as they would have been.
  for (int index = processed + 1; index < nodes; ++index) {
    if (options.threads > 0) {
      std::lock_guard<std::mutex> lock(b.mu_);
      b.queue_.push_back(index);
      b.work_cv_.notify_one();
    } else {
      b.Process(index);
    }
  }
  return backend;
}

}  // namespace waymark::laser_slam

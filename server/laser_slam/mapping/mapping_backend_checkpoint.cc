#include "server/laser_slam/mapping/mapping_backend.h"

// The back end's checkpoint (MappingBackend::Serialize / Deserialize): nodes with their points,
// submaps, constraints, counters and the loop search's state, versioned; older versions load.

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/common/binary_io.h"
#include "server/laser_slam/mapping/graph_codec.h"
#include "server/laser_slam/input_bounds.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kMagic = 0x5047574d;  // "MWGP"
// 2: the newest node Process handled, so that nodes still waiting for the back end's thread are
// processed after a resume (version 1 counted them as processed: their loop searches were lost,
// and a session resumed from a checkpoint ended 0.3 m away from the uninterrupted one on Intel).
// 3: the node of the last closure and the global searches' turn (issue 33's loop search).
// 4: what the front end learned of the EKF's steps (ekf_step_agreement.h); older checkpoints
// start it afresh.
// 5: global matches waiting for a second, agreeing match (confirm_global_closures); older
// checkpoints have none.
// 6: pruning (prune_redundant_submaps): per node whether it is pruned, its anchor and its chain
// step's sigma; per submap whether it was decided and pruned; the kept submaps' coverage cells.
// Older checkpoints have nothing pruned and every submap undecided.
constexpr std::uint32_t kVersion = 6;

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
    PutPoints(w, *n.points);
    PutPose(w, n.odometry);
    for (int i = 0; i < 3; ++i) w.Put(n.odometry_variance(i));
    w.Put<std::uint8_t>(n.pruned);
    w.Put<std::int32_t>(n.anchor);
    w.Put<std::int32_t>(n.after);
    PutPose(w, n.from_anchor);
    PutPose(w, n.from_after);
    w.Put(n.weight);
    for (int i = 0; i < 3; ++i) w.Put(n.chain_sigma(i));
  }
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(submaps_.size()));
  for (const Submap& s : submaps_) {
    w.Put<std::int32_t>(s.first);
    w.Put<std::int32_t>(s.count);
    w.Put<std::uint8_t>(s.complete);
    w.Put<std::uint32_t>(static_cast<std::uint32_t>(s.frozen.size()));
    for (const Pose2& p : s.frozen) PutPose(w, p);
    w.Put<std::uint8_t>(static_cast<std::uint8_t>(s.decided | (s.pruned << 1)));
  }
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(constraints_.size()));
  for (const GraphConstraint& c : constraints_) PutConstraint(w, c);
  w.Put(tie_travel_);
  w.Put<std::int32_t>(closures_since_optimize_);
  w.Put(revision_);
  w.Put<std::int32_t>(processed_);
  for (int v : {stats_.searches, stats_.candidates, stats_.closures_accepted,
                stats_.closures_rejected, stats_.closures_switched_off, stats_.optimizations}) {
    w.Put<std::int32_t>(v);
  }
  w.Put<std::int32_t>(tie_node_);
  w.Put<std::int32_t>(last_global_search_);
  w.Put<std::int32_t>(global_cursor_);
  PutPose(w, dead_reckoning_);
  for (int i = 0; i < 3; ++i) w.Put(motion_variance_(i));
  PutPose(w, last_local_);
  double agreement[EkfStepAgreement::kValues];
  ekf_agreement_.Values(agreement);
  for (double v : agreement) w.Put(v);
  w.Put<std::uint8_t>(ekf_shown_);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(pending_closures_.size()));
  for (const PendingClosure& p : pending_closures_) {
    w.Put<std::int32_t>(p.submap);
    PutConstraint(w, p.loop);
  }
  // Sorted: the same set gives the same bytes whatever order it was filled in.
  std::vector<std::int64_t> cells(coverage_.begin(), coverage_.end());
  std::sort(cells.begin(), cells.end());
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(cells.size()));
  for (const std::int64_t cell : cells) w.Put(cell);
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
    if (!r.Get(&n.scan) || !r.Get(&n.stamp) || !r.Get(&n.travel) || !GetPose(r, &n.local) ||
        !GetPose(r, &n.global) || n.scan <= previous_scan) {
      return corrupt("node");
    }
    previous_scan = n.scan;
    PointCloud cloud;
    if (!GetPoints(r, 100000, &cloud)) return corrupt("node points");
    n.points = std::make_shared<const PointCloud>(std::move(cloud));
    if (version >= 3) {
      if (!GetPose(r, &n.odometry) || !GetVariance(r, &n.odometry_variance)) {
        return corrupt("node odometry");
      }
    } else {
      n.odometry = n.local;  // older graphs: the EKF's steps were the odometry
    }
    if (version >= 6) {
      std::uint8_t pruned = 0;
      if (!r.Get(&pruned) || pruned > 1 || !r.Get(&n.anchor) || !r.Get(&n.after) ||
          !GetPose(r, &n.from_anchor) || !GetPose(r, &n.from_after) || !r.Get(&n.weight) ||
          !(n.weight >= 0.0 && n.weight <= 1.0) || !GetVariance(r, &n.chain_sigma)) {
        return corrupt("node pruning");
      }
      n.pruned = pruned == 1;
      const int index = static_cast<int>(&n - b.nodes_.data());
      // A pruned node's ends are kept nodes before and after it; a kept node has none.
      if (n.pruned ? (n.anchor < 0 || n.anchor >= index || n.after <= index ||
                      n.after >= static_cast<int>(count) || !n.points->empty())
                   : (n.anchor != -1 || n.after != -1)) {
        return corrupt("node pruning");
      }
    }
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
    if (version >= 6) {
      std::uint8_t flags = 0;
      if (!r.Get(&flags) || flags > 3 || flags == 2) return corrupt("submap pruning");
      s.decided = (flags & 1) != 0;
      s.pruned = (flags & 2) != 0;
      if (s.pruned) {
        for (int j = s.first; j < s.first + s.count; ++j) {
          if (!b.nodes_[j].pruned) return corrupt("submap pruning");
        }
        ++b.stats_.submaps_pruned;
        b.stats_.nodes_pruned += s.count;
      }
    }
  }
  if (!r.Get(&count) || count > 100000000 || count > r.remaining() / kConstraint) {
    return corrupt("constraint count");
  }
  b.constraints_.resize(count);
  for (GraphConstraint& c : b.constraints_) {
    if (!GetConstraint(r, nodes, &c)) return corrupt("constraint");
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
  if (version >= 3) {
    if (!r.Get(&b.tie_node_) || !r.Get(&b.last_global_search_) || !r.Get(&b.global_cursor_) ||
        !GetPose(r, &b.dead_reckoning_) || !GetVariance(r, &b.motion_variance_) ||
        !GetPose(r, &b.last_local_) ||
        b.tie_node_ < -1 || b.tie_node_ >= nodes || b.last_global_search_ >= nodes ||
        b.last_global_search_ < kNoGlobalSearchYet ||
        b.global_cursor_ < -1 || b.global_cursor_ >= static_cast<int>(b.submaps_.size())) {
      return corrupt("loop search state");
    }
  } else {
    if (nodes > 0) b.dead_reckoning_ = b.last_local_ = b.nodes_.back().local;
  }
  if (version < 3 && b.tie_travel_ >= 0.0) {
    // Older checkpoints kept the travel of the last closure: its last node at that travel.
    for (int i = 0; i < nodes && b.nodes_[i].travel <= b.tie_travel_; ++i) b.tie_node_ = i;
  }
  if (version >= 4) {
    double agreement[EkfStepAgreement::kValues];
    for (double& v : agreement) {
      if (!r.Get(&v)) return corrupt("front end state");
    }
    std::optional<EkfStepAgreement> restored = EkfStepAgreement::FromValues(agreement);
    std::uint8_t shown = 0;
    if (!restored || !r.Get(&shown) || shown > 1) return corrupt("front end state");
    b.ekf_agreement_ = *restored;
    b.ekf_shown_ = shown == 1;
  }
  if (version >= 5) {
    std::uint32_t pending = 0;
    if (!r.Get(&pending) || pending > 64 || pending > r.remaining() / (4 + kConstraint)) {
      return corrupt("pending closures");
    }
    b.pending_closures_.resize(pending);
    for (PendingClosure& p : b.pending_closures_) {
      if (!r.Get(&p.submap) || p.submap < 0 || p.submap >= static_cast<int>(b.submaps_.size()) ||
          !GetConstraint(r, nodes, &p.loop) || p.loop.kind != GraphConstraint::Kind::kLoop ||
          !b.submaps_[p.submap].complete || b.submaps_[p.submap].first != p.loop.from) {
        return corrupt("pending closure");
      }
    }
  }
  if (version >= 6) {
    std::uint32_t cells = 0;
    if (!r.Get(&cells) || cells > r.remaining() / sizeof(std::int64_t)) {
      return corrupt("coverage");
    }
    b.coverage_.reserve(cells);
    for (std::uint32_t i = 0; i < cells; ++i) {
      std::int64_t cell = 0;
      if (!r.Get(&cell) || !b.coverage_.insert(cell).second) return corrupt("coverage");
    }
  }
  for (const Node& n : b.nodes_) {
    if (n.pruned && (b.nodes_[n.anchor].pruned || b.nodes_[n.after].pruned)) {
      return corrupt("node pruning");
    }
  }
  if (!r.done()) return corrupt("trailing bytes");
  // The chain's uncertainty of the processed nodes: their steps' sigmas (version 6), or from
  // their chain constraints (older checkpoints, which pruned nothing).
  std::vector<Eigen::Vector3d> chain_sigma(nodes, Eigen::Vector3d::Zero());
  if (version >= 6) {
    for (int i = 0; i < nodes; ++i) chain_sigma[i] = b.nodes_[i].chain_sigma;
  } else {
    for (const GraphConstraint& c : b.constraints_) {
      if (c.kind == GraphConstraint::Kind::kChain && c.to > 0) chain_sigma[c.to] = c.sigma;
    }
  }
  for (int index = 0; index <= processed; ++index) {
    b.AppendChainUncertaintyLocked(index, chain_sigma[index]);
  }
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

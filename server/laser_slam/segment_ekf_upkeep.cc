#include "server/laser_slam/segment_ekf.h"
#include "server/laser_slam/segment_ekf_internal.h"

// The segment map's upkeep after each observation (the paper's SegmentEkf, split from
// segment_ekf.cc by job): segments outside the active window frozen, tentative ones pruned,
// segments found to be one wall merged.

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Cholesky>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/sp_jacobians.h"

namespace waymark::laser_slam {
namespace {

// Variance given to the perfect "same wall" constraint of a merge (keeps S invertible).
constexpr double kMergeConstraintVariance = 1e-10;

}  // namespace

int SegmentEkf::FreezeOutsideWindow(std::uint64_t scan_index) {
  const int count = static_cast<int>(state_.segments.size());
  std::vector<char> freeze(count, 0);
  const std::vector<int> near = NearbySegments(options_.active_radius);
  std::vector<char> is_near(count, 0);
  for (int i : near) is_near[i] = 1;
  int active = count;
  for (int i = 0; i < count; ++i) {
    const SegmentEntity& s = state_.segments[i];
    if (!is_near[i] && scan_index - s.last_seen_scan >=
                           static_cast<std::uint64_t>(options_.freeze_after_scans)) {
      freeze[i] = 1;
      --active;
    }
  }
  if (active > options_.max_active_segments) {
    std::vector<int> order;
    for (int i = 0; i < count; ++i) {
      if (!freeze[i]) order.push_back(i);
    }
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      return state_.segments[a].last_seen_scan < state_.segments[b].last_seen_scan;
    });
    for (int i = 0; i < active - options_.max_active_segments; ++i) freeze[order[i]] = 1;
  }
  std::vector<int> remove;
  std::vector<SegmentEntity> kept;
  for (int i = 0; i < count; ++i) {
    SegmentEntity& s = state_.segments[i];
    if (!freeze[i]) {
      kept.push_back(s);
      continue;
    }
    FrozenSegment f;
    f.line_covariance << state_.at(s.dof[0], s.dof[0]), state_.at(s.dof[0], s.dof[1]),
        state_.at(s.dof[1], s.dof[0]), state_.at(s.dof[1], s.dof[1]);
    f.left_variance = s.dof[2] >= 0 ? state_.at(s.dof[2], s.dof[2]) : 0.0;
    f.right_variance = s.dof[3] >= 0 ? state_.at(s.dof[3], s.dof[3]) : 0.0;
    for (int d : SegmentDofs(s)) remove.push_back(d);
    f.entity = s;
    f.entity.dof = {-1, -1, -1, -1};
    state_.frozen.push_back(f);
  }
  const int frozen = count - static_cast<int>(kept.size());
  if (frozen == 0) return 0;
  state_.segments = std::move(kept);
  state_.RemoveDofs(remove);
  return frozen;
}

int SegmentEkf::PruneTentative(std::uint64_t scan_index) {
  std::vector<int> remove;
  std::vector<SegmentEntity> kept;
  kept.reserve(state_.segments.size());
  for (const SegmentEntity& s : state_.segments) {
    const bool expired = scan_index - s.first_seen_scan >=
                         static_cast<std::uint64_t>(options_.confirm_window);
    if (s.observations < options_.confirm_observations && expired) {
      for (int d : SegmentDofs(s)) remove.push_back(d);
    } else {
      kept.push_back(s);
    }
  }
  const int pruned = static_cast<int>(state_.segments.size() - kept.size());
  if (pruned == 0) return 0;
  // Dropping a Gaussian's components is exact marginalisation: nothing else changes.
  state_.segments = std::move(kept);
  state_.RemoveDofs(remove);
  return pruned;
}

int SegmentEkf::MergeSegments(std::uint64_t scan_index) {
  int merged = 0;
  // Pairs among the segments seen in this scan and their neighbours.
  const std::vector<int> nearby = NearbySegments(options_.association_radius);
  std::vector<std::uint64_t> recent;
  for (int i : nearby) {
    if (state_.segments[i].last_seen_scan == scan_index) recent.push_back(state_.segments[i].id);
  }
  for (std::uint64_t id : recent) {
    bool again = true;
    while (again) {
      again = false;
      auto it = std::find_if(state_.segments.begin(), state_.segments.end(),
                             [&](const SegmentEntity& s) { return s.id == id; });
      if (it == state_.segments.end()) break;
      const int keep = static_cast<int>(it - state_.segments.begin());
      const std::vector<int> around = NearbySegments(options_.association_radius);
      for (int other : around) {
        if (other == keep) continue;
        if (MergePair(keep, other)) {
          ++merged;
          again = true;  // indices moved; look again from the merged segment
          break;
        }
      }
    }
  }
  return merged;
}

bool SegmentEkf::MergePair(int keep, int drop) {
  SegmentEntity& a = state_.segments[keep];
  const SegmentEntity& b0 = state_.segments[drop];
  const bool flip = std::abs(NormalizeAngle(b0.frame.theta - a.frame.theta)) > M_PI / 2;
  Pose2 bframe = b0.frame;
  if (flip) bframe.theta = NormalizeAngle(bframe.theta + M_PI);
  const Pose2 z0 = Relative(a.frame, bframe);
  if (std::abs(z0.theta) > kMaxMatchAngle || std::abs(z0.y) > kMaxMatchOffset) return false;
  const double bl = flip ? -b0.right : b0.left, br = flip ? -b0.left : b0.right;
  const double ct = std::cos(z0.theta);
  const double lo = z0.x + bl * ct, hi = z0.x + br * ct;
  if (hi < a.left - options_.merge_gap || lo > a.right + options_.merge_gap) return false;

  // Joint test of "same line": f = (z_y, z_theta) of b's line in a's frame, with b's line
  // perturbation c (sign of c_y flips with the frame when b is described from its other end).
  const RelativeLine rel = RelateLines(a.frame, bframe, Pose2{});
  const double flip_y = flip ? -1.0 : 1.0;
  std::vector<Row> rows;
  for (int r = 1; r <= 2; ++r) {
    Row row;
    row.innovation = -rel.z(r);
    row.Add(a.dof[0], rel.d_a(r, 0));
    row.Add(a.dof[1], rel.d_a(r, 1));
    row.Add(b0.dof[0], flip_y * rel.d_c(r, 0));
    row.Add(b0.dof[1], rel.d_c(r, 1));
    rows.push_back(row);
  }
  Eigen::Matrix2d s = Eigen::Matrix2d::Zero();
  for (int r = 0; r < 2; ++r) {
    for (int q = 0; q < 2; ++q) {
      for (int i = 0; i < rows[r].count; ++i) {
        for (int j = 0; j < rows[q].count; ++j) {
          s(r, q) += rows[r].value[i] * state_.at(rows[r].dof[i], rows[q].dof[j]) * rows[q].value[j];
        }
      }
    }
  }
  const Eigen::Vector2d f = rel.z.tail<2>();
  const double d = f.dot(s.ldlt().solve(f));
  if (!std::isfinite(d) || d > options_.merge_chi2) return false;

  const std::uint64_t keep_id = a.id, drop_id = b0.id;
  if (!Update(rows, Eigen::Matrix2d::Identity() * kMergeConstraintVariance)) return false;
  // Indices are stable through Update (no dofs added or removed).
  SegmentEntity& k = state_.segments[keep];
  SegmentEntity b = state_.segments[drop];
  Pose2 bf = b.frame;
  if (flip) bf.theta = NormalizeAngle(bf.theta + M_PI);
  const Pose2 z = Relative(k.frame, bf);
  const double c2 = std::cos(z.theta);
  // b's endpoints on k's line, in k's direction.
  struct End { double x; EndpointType type; int dof; };
  const End b_left = flip ? End{z.x - b.right * c2, b.right_type, b.dof[3]}
                          : End{z.x + b.left * c2, b.left_type, b.dof[2]};
  const End b_right = flip ? End{z.x - b.left * c2, b.left_type, b.dof[2]}
                           : End{z.x + b.right * c2, b.right_type, b.dof[3]};
  std::vector<int> remove = {b.dof[0], b.dof[1]};
  std::vector<int> flip_sign;
  auto take = [&](const End& end, double& k_end, EndpointType& k_type, int& k_dof, bool outward) {
    const bool further = outward ? end.x > k_end : end.x < k_end;
    if (further) {
      if (k_dof >= 0) remove.push_back(k_dof);
      k_end = end.x;
      k_type = end.type;
      k_dof = end.dof;  // b's endpoint dof moves to k (-1 if virtual)
      if (end.dof >= 0 && flip) flip_sign.push_back(end.dof);
    } else if (end.dof >= 0) {
      remove.push_back(end.dof);
    }
  };
  take(b_left, k.left, k.left_type, k.dof[2], /*outward=*/false);
  take(b_right, k.right, k.right_type, k.dof[3], /*outward=*/true);
  k.observations += b.observations;
  k.last_seen_scan = std::max(k.last_seen_scan, b.last_seen_scan);
  // A dof seen from b's other end moves the endpoint the other way along k's line.
  for (int d : flip_sign) {
    Eigen::MatrixXd q = -Eigen::MatrixXd::Identity(1, 1);
    ApplyToCovariance({d}, q);
  }
  // Forget b before renumbering so that no entity points at a removed dof.
  state_.segments.erase(state_.segments.begin() + drop);
  state_.RemoveDofs(remove);
  auto it = std::find_if(state_.segments.begin(), state_.segments.end(),
                         [&](const SegmentEntity& s) { return s.id == keep_id; });
  if (it != state_.segments.end()) Recentre(*it);
  (void)drop_id;
  return true;
}

}  // namespace waymark::laser_slam

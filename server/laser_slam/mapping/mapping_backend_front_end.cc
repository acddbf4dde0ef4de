#include "server/laser_slam/mapping/mapping_backend.h"

// The back end's front end (docs/laser-slam.md, "Local matching"): each node's scan against the
// local map, fused with the EKF's step, and what the session learns of the EKF's steps from the
// matches (ekf_step_agreement.h).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "server/common/stopwatch.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/local_matcher.h"

namespace waymark::laser_slam {
namespace {

// a - b per axis, the heading difference wrapped.
Eigen::Vector3d Difference(const Pose2& a, const Pose2& b) {
  return Eigen::Vector3d(a.x - b.x, a.y - b.y, NormalizeAngle(a.theta - b.theta));
}

}  // namespace

Eigen::Vector3d MappingBackend::LocalSigmaFloor() const {
  return Eigen::Vector3d(options_.local_sigma_xy, options_.local_sigma_xy,
                         options_.local_sigma_theta);
}

SearchWindow MappingBackend::LocalWindow(const Eigen::Vector3d& sigma) const {
  SearchWindow window;
  window.xy = std::min(options_.max_window_xy,
                       std::max(options_.local_window_min_xy,
                                options_.local_window_sigmas * std::max(sigma(0), sigma(1))));
  window.theta = std::min(M_PI, std::max(options_.local_window_min_theta,
                                         options_.local_window_sigmas * sigma(2)));
  return window;
}

void MappingBackend::MatchLocalMap(int index) {
  const auto start = Clock::now();
  PointCloud local_map;
  Pose2 step;
  SearchWindow window;
  Eigen::Vector3d step_sigma;
  Eigen::Vector3d disagreement = Eigen::Vector3d::Zero();
  std::shared_ptr<const PointCloud> query;
  int chain = -1;
  // The odometry's step where the EKF's leaves it by more than the odometry's noise allows: a
  // second hypothesis (local_odometry_hypothesis), and the step of a scan nothing places
  // (local_unmatched_odometry).
  std::optional<Pose2> odometry_apart;
  Eigen::Vector3d odometry_sigma;
  {
    std::lock_guard<std::mutex> lock(mu_);
    const Node& previous = nodes_[index - 1];
    const Node& node = nodes_[index];
    const Pose2 ekf_step = Relative(previous.local, node.local);
    const Pose2 odometry_step = Relative(previous.odometry, node.odometry);
    step = options_.local_prior == MappingOptions::LocalPrior::kOdometry ? odometry_step
                                                                         : ekf_step;
    // Two estimates of one step: where they disagree, the prior is as uncertain as their
    // difference (the EKF associated wrongly, or the wheels slipped), and the walls decide.
    disagreement = Difference(ekf_step, odometry_step);
    query = node.points;
    // The local map in the previous node's frame, so that the prior is the EKF's step itself.
    for (int j = std::max(0, index - options_.local_map_nodes); j < index; ++j) {
      AppendTransformed(*nodes_[j].points, Relative(previous.global, nodes_[j].global),
                        &local_map);
    }
    chain = ChainConstraintLocked(index);
    if (chain < 0) return;
    const Eigen::Vector3d floor = LocalSigmaFloor();
    Eigen::Vector3d sigma = constraints_[chain].sigma;
    if (options_.local_prior == MappingOptions::LocalPrior::kOdometry) {
      sigma = nodes_[index].odometry_variance.cwiseSqrt().cwiseMax(floor);
    } else if (options_.local_prior == MappingOptions::LocalPrior::kEkfWithinOdometry) {
      sigma = (nodes_[index].odometry_variance + disagreement.cwiseAbs2()).cwiseSqrt().cwiseMax(
          floor);
    }
    step_sigma = sigma;
    window = LocalWindow(sigma);
    odometry_sigma = nodes_[index].odometry_variance.cwiseSqrt().cwiseMax(floor);
    if (options_.local_prior == MappingOptions::LocalPrior::kEkfWithinOdometry &&
        (disagreement.array().abs() > options_.local_window_sigmas * odometry_sigma.array())
            .any()) {
      odometry_apart = odometry_step;
    }
  }
  LocalMatchSettings settings;
  settings.grid_resolution = options_.grid_resolution;
  settings.grid_sigma = options_.grid_sigma;
  settings.min_score = options_.local_min_score;
  settings.points_per_observation = options_.local_points_per_observation;
  settings.ignore_edge_translation = options_.local_ignore_edge_translation;
  const PointCloud thinned = ThinPoints(local_map, options_.point_cell);
  std::optional<LocalMatchResult> match = MatchLocally(
      thinned, *query, step, step_sigma.cwiseAbs2().asDiagonal(), window, settings);
  bool widened = false;
  if ((!match || match->at_heading_edge) && options_.local_widen_at_heading_edge) {
    SearchWindow wide;
    wide.xy = std::max(window.xy, options_.local_wide_window_xy);
    wide.theta = std::min(M_PI, std::max(window.theta, options_.local_wide_window_theta));
    const double sigmas = options_.local_window_sigmas;
    const Eigen::Vector3d wide_sigma(wide.xy / sigmas, wide.xy / sigmas, wide.theta / sigmas);
    std::optional<LocalMatchResult> again = MatchLocally(
        thinned, *query, step, wide_sigma.cwiseAbs2().asDiagonal(), wide, settings);
    if (again && (!match || again->score > match->score)) {
      match = std::move(again);
      widened = true;
    }
  }
  bool odometry_won = false;
  if (odometry_apart && options_.local_odometry_hypothesis) {
    // The walls decide between the two steps: the better-scoring match is kept.
    std::optional<LocalMatchResult> around_odometry =
        MatchLocally(thinned, *query, *odometry_apart,
                     odometry_sigma.cwiseAbs2().asDiagonal(), LocalWindow(odometry_sigma),
                     settings);
    if (around_odometry && (!match || around_odometry->score > match->score)) {
      match = std::move(around_odometry);
      odometry_won = true;
    }
  }
  EkfTrust trust;
  if (match && !odometry_won && !widened &&
      options_.local_prior == MappingOptions::LocalPrior::kEkfWithinOdometry) {
    trust = TrustEkfWhereShown(step, disagreement, odometry_sigma, step_sigma, &*match);
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (odometry_won) ++stats_.local_odometry_wins;
  if (widened) ++stats_.local_widened;
  if (trust.axes > 0) ++stats_.local_ekf_trusted;
  if (trust.translation_dropped) ++stats_.local_edge_translations_dropped;
  GraphConstraint& c = constraints_[chain];
  if (!match) {
    // The prior alone: with the odometry prior, its step and its noise replace the EKF's. An
    // EKF step the odometry's noise cannot explain (its association went wrong: freiburg-campus
    // at high noise stepped 16 m where the wheels said 1 m) gives way to the odometry's.
    if (options_.local_prior != MappingOptions::LocalPrior::kEkf) {
      const bool by_odometry = odometry_apart && options_.local_unmatched_odometry;
      c.relative = by_odometry ? *odometry_apart : step;
      c.sigma = by_odometry ? odometry_sigma : step_sigma;
      nodes_[index].global = Compose(nodes_[index - 1].global, c.relative);
      if (by_odometry) ++stats_.local_unmatched_odometry;
      FollowPredecessorsLocked(index + 1);
    }
    ++stats_.local_unmatched;
    return;
  }
  c.relative = match->pose;
  // The fused step's marginal sigmas, at least local_sigma_xy / _theta: the Laplace
  // approximation knows the walls, not how well the local map itself was placed.
  c.sigma = match->covariance.diagonal().cwiseSqrt().cwiseMax(LocalSigmaFloor());
  c.score = match->score;
  nodes_[index].global = Compose(nodes_[index - 1].global, match->pose);
  FollowPredecessorsLocked(index + 1);
  ++stats_.local_matches;
  stats_.local_ms.push_back(MsSince(start));
  if (trust.axes == 3 && !ekf_shown_) {
    ekf_shown_ = true;
    RedecideEarlierStepsLocked(index, trust.variance);
  }
}

void MappingBackend::RedecideEarlierStepsLocked(int index, const Eigen::Vector3d& variance) {
  // While the graph is still the chain alone (no loop constraint).
  for (const GraphConstraint& c : constraints_) {
    if (c.kind != GraphConstraint::Kind::kChain) return;
  }
  const Eigen::Vector3d floor = LocalSigmaFloor();
  const double sigmas = options_.local_window_sigmas;
  for (int j = 1; j < index; ++j) {
    const int chain = ChainConstraintLocked(j);
    if (chain < 0) continue;
    const Pose2 ekf = Relative(nodes_[j - 1].local, nodes_[j].local);
    const Pose2 odometry = Relative(nodes_[j - 1].odometry, nodes_[j].odometry);
    const Eigen::Vector3d odometry_sigma = nodes_[j].odometry_variance.cwiseSqrt().cwiseMax(floor);
    const Eigen::Vector3d difference = Difference(ekf, odometry);
    // As TrustEkfWhereShown: not a step where the EKF left the odometry's noise, nor one where
    // the walls left both (a turn the odometry did not see, found in the wide window).
    if ((difference.array().abs() > sigmas * odometry_sigma.array()).any()) continue;
    const Eigen::Vector3d matched = Difference(constraints_[chain].relative, ekf);
    if ((matched.array().abs() > sigmas * odometry_sigma.array() +
                                     Eigen::Array3d(options_.local_window_min_xy,
                                                    options_.local_window_min_xy,
                                                    options_.local_window_min_theta))
            .any()) {
      continue;
    }
    constraints_[chain].relative = ekf;
    constraints_[chain].sigma = variance.cwiseSqrt().cwiseMax(floor);
    ++stats_.local_ekf_redecided;
  }
  for (int j = 1; j <= index; ++j) {
    const int chain = ChainConstraintLocked(j);
    const Pose2 step = chain >= 0 ? constraints_[chain].relative
                                  : Relative(nodes_[j - 1].local, nodes_[j].local);
    nodes_[j].global = Compose(nodes_[j - 1].global, step);
  }
  FollowPredecessorsLocked(index + 1);
  // Submaps frozen on the old poses are frozen again, and grids built on them are dropped
  // (search_mu_ is held: the cache is the searches').
  for (Submap& submap : submaps_) {
    if (submap.frozen.empty()) continue;
    const Pose2 anchor = nodes_[submap.first].global;
    for (int j = 0; j < static_cast<int>(submap.frozen.size()); ++j) {
      submap.frozen[j] = Relative(anchor, nodes_[submap.first + j].global);
    }
  }
  pyramid_cache_ = PyramidCache(kPyramidCacheBytes);
  seen_masks_.clear();
  // The chain's uncertainty of the nodes processed before this one, from their new sigmas.
  chain_.clear();
  for (int j = 0; j < index; ++j) {
    const int chain = ChainConstraintLocked(j);
    AppendChainUncertaintyLocked(
        j, chain >= 0 ? constraints_[chain].sigma : Eigen::Vector3d::Zero().eval());
  }
}

MappingBackend::EkfTrust MappingBackend::TrustEkfWhereShown(
    const Pose2& ekf_step, const Eigen::Vector3d& ekf_minus_odometry,
    const Eigen::Vector3d& odometry_sigma, const Eigen::Vector3d& prior_sigma,
    LocalMatchResult* match) {
  const Eigen::Vector3d ekf_minus_match = Difference(ekf_step, match->matched);
  // The match's own variance per axis: the inverse of its information there (the others held).
  Eigen::Vector3d match_variance;
  for (int axis = 0; axis < 3; ++axis) {
    const double information = match->information(axis, axis);
    match_variance(axis) =
        information > 0.0 ? 1.0 / information : std::numeric_limits<double>::infinity();
  }
  const double sigmas = options_.local_window_sigmas;
  const Eigen::Vector3d floor = LocalSigmaFloor();
  EkfTrust trust;
  if (options_.local_learned_prior) {
    // An axis where the session has shown its EKF's steps better than its matches and not biased
    // against them, and where this step stays within the odometry's noise of the odometry's step
    // (a wrong association leaves it).
    std::array<bool, 3> shown;
    std::array<std::optional<double>, 3> ekf_variance;
    for (int axis = 0; axis < 3; ++axis) {
      const std::optional<double>& ekf = ekf_variance[axis] =
          ekf_agreement_.EkfVariance(axis, floor(axis) * floor(axis));
      const std::optional<double> matches = ekf_agreement_.MatchVariance(axis);
      shown[axis] = ekf && matches && *ekf < *matches && !ekf_agreement_.Biased(axis, sigmas) &&
                    std::abs(ekf_minus_odometry(axis)) <= sigmas * odometry_sigma(axis);
    }
    // A match that found no maximum (on its window's edge) gives no translation where the EKF
    // has shown itself better: the simulator's ring corridor had two such matches 15-23 cm off,
    // each fused halfway. Elsewhere it counts as before (local_ignore_edge_translation).
    const bool drop_translation = match->at_window_edge && shown[0] && shown[1];
    if (drop_translation) {
      match->information.topRows<2>().setZero();
      match->information.leftCols<2>().setZero();
    }
    // This step's EKF and match agree within what the session has shown them worth: not a step
    // where one of them went wrong.
    bool agree = true;
    for (int axis = drop_translation ? 2 : 0; axis < 3; ++axis) {
      const std::optional<double>& ekf = ekf_variance[axis];
      if (ekf && ekf_minus_match(axis) * ekf_minus_match(axis) >
                     sigmas * sigmas * (*ekf + match_variance(axis))) {
        agree = false;
      }
    }
    // The EKF's step is trusted to its learned variance on the shown axes. The match keeps its
    // say, at its own weight: the local map it is matched against repairs what a step that was
    // not trusted (an EKF that jumped) got wrong, where the EKF's steps alone would carry it on.
    Eigen::Vector3d variance = prior_sigma.cwiseAbs2();
    int axes = 0;
    for (int axis = 0; agree && axis < 3; ++axis) {
      if (shown[axis]) {
        variance(axis) = std::min(variance(axis), *ekf_variance[axis]);
        ++axes;
      }
    }
    if (axes > 0 || drop_translation) FuseWithPrior(ekf_step, variance.asDiagonal(), match);
    trust.axes = axes;
    trust.translation_dropped = drop_translation;
    trust.variance = variance;
  }
  if (!match->at_window_edge) {
    // Only axes where the match knows more than the prior (along a corridor without ends it
    // knows nothing of the distance, and its variance there estimates nothing).
    const Eigen::Array3i informative =
        (match_variance.array() < prior_sigma.cwiseAbs2().array()).cast<int>();
    ekf_agreement_.Add(ekf_minus_match, match_variance, informative);
  }
  return trust;
}

}  // namespace waymark::laser_slam

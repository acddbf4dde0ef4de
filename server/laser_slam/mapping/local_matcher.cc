#include "server/laser_slam/mapping/local_matcher.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/likelihood_grid.h"

namespace waymark::laser_slam {

Eigen::Matrix3d MatchInformation(const LikelihoodGrid& grid, const PointCloud& points,
                                 const Pose2& pose, double observations) {
  double mean_range = 0.0;
  for (const Eigen::Vector2f& p : points) mean_range += p.norm();
  mean_range = std::max(grid.resolution, mean_range / std::max<size_t>(1, points.size()));
  const Eigen::Vector3d h(grid.resolution, grid.resolution, grid.resolution / mean_range);
  const auto score = [&](const Eigen::Vector3d& d) {
    return ScoreAt(grid, points, Pose2{pose.x + d(0), pose.y + d(1), pose.theta + d(2)});
  };
  const double centre = score(Eigen::Vector3d::Zero());
  Eigen::Matrix3d hessian;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d ei = h(i) * Eigen::Vector3d::Unit(i);
    hessian(i, i) = (score(ei) - 2.0 * centre + score(-ei)) / (h(i) * h(i));
    for (int j = 0; j < i; ++j) {
      const Eigen::Vector3d ej = h(j) * Eigen::Vector3d::Unit(j);
      hessian(i, j) = hessian(j, i) =
          (score(ei + ej) - score(ei - ej) - score(ej - ei) + score(-ei - ej)) /
          (4.0 * h(i) * h(j));
    }
  }
  // Information is the negative curvature; a direction where the score does not fall (a
  // corridor's axis, or noise) carries none.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(-observations * hessian);
  const Eigen::Vector3d values = eigen.eigenvalues().cwiseMax(0.0);
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

namespace {

// The local map's points that can bear on a match in the window: a query point lands within
// its range plus the window's reach of the prior, and a cell's value depends on points within
// 3 sigma of it; the pyramid's coarsest level reads 2^depth cells further. Leaving the rest
// out changes no score (the grid keeps the whole map's lattice: GridFrameOf), keeps
// the grid as small as the window (a restored checkpoint's nodes a kilometre apart made a grid
// of 10^9 cells), and builds faster.
PointCloud Reachable(const PointCloud& local_map, const PointCloud& query, const Pose2& prior,
                     const SearchWindow& window, int depth, const LocalMatchSettings& settings) {
  float reach = 0.0f;
  for (const Eigen::Vector2f& p : query) reach = std::max(reach, p.norm());
  const double radius = reach + std::sqrt(2.0) * window.xy + 3.0 * settings.grid_sigma +
                        ((1 << depth) + 2) * settings.grid_resolution;
  const Eigen::Vector2f centre(static_cast<float>(prior.x), static_cast<float>(prior.y));
  const float r2 = static_cast<float>(radius * radius);
  PointCloud kept;
  kept.reserve(local_map.size());
  for (const Eigen::Vector2f& p : local_map) {
    if ((p - centre).squaredNorm() <= r2) kept.push_back(p);
  }
  return kept;
}

}  // namespace

std::optional<LocalMatchResult> MatchLocally(const PointCloud& local_map, const PointCloud& query,
                                             const Pose2& prior,
                                             const Eigen::Matrix3d& prior_covariance,
                                             const SearchWindow& window,
                                             const LocalMatchSettings& settings) {
  if (local_map.empty() || query.empty()) return std::nullopt;
  // The pyramid needs only as many levels as the window has cells: a window of a few cells is
  // searched almost exhaustively, and building levels it never visits would cost more.
  const double half_cells = std::max(1.0, window.xy / settings.grid_resolution);
  const int depth = std::clamp(static_cast<int>(std::ceil(std::log2(half_cells))), 0, 6);
  // On the lattice of the whole local map (its cells where they would be had every point been
  // drawn), so that leaving points out moves no cell.
  const SearchPyramid pyramid(
      BuildLikelihoodGrid(Reachable(local_map, query, prior, window, depth, settings),
                          settings.grid_resolution, settings.grid_sigma,
                          GridFrameOf(local_map, settings.grid_resolution, settings.grid_sigma)),
      depth);
  const std::optional<GridMatch> match =
      MatchInWindow(pyramid, query, prior, window, settings.min_score);
  if (!match) return std::nullopt;
  LocalMatchResult result;
  result.matched = match->pose;
  result.score = match->score;
  result.at_window_edge = match->at_window_edge;
  result.at_heading_edge = match->at_heading_edge;
  result.information =
      MatchInformation(pyramid.base(), query, match->pose,
                       static_cast<double>(query.size()) / settings.points_per_observation);
  if (result.at_window_edge && settings.ignore_edge_translation) {
    result.information.topRows<2>().setZero();
    result.information.leftCols<2>().setZero();
  }
  FuseWithPrior(prior, prior_covariance, &result);
  return result;
}

void FuseWithPrior(const Pose2& prior, const Eigen::Matrix3d& prior_covariance,
                   LocalMatchResult* match) {
  // Gaussian fusion of the match with the prior, in (x, y, theta) of the local map's frame.
  const Eigen::Matrix3d prior_information = prior_covariance.inverse();
  const Eigen::Matrix3d information = match->information + prior_information;
  const Eigen::LDLT<Eigen::Matrix3d> solver(information);
  const Eigen::Vector3d matched(match->matched.x, match->matched.y, match->matched.theta);
  Eigen::Vector3d from_prior(prior.x, prior.y, prior.theta);
  from_prior(2) = matched(2) + NormalizeAngle(from_prior(2) - matched(2));
  const Eigen::Vector3d fused =
      solver.solve(match->information * matched + prior_information * from_prior);
  match->pose = Pose2{fused(0), fused(1), NormalizeAngle(fused(2))};
  match->covariance = solver.solve(Eigen::Matrix3d::Identity());
}

}  // namespace waymark::laser_slam

#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCAL_MATCHER_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCAL_MATCHER_H_

// The back end's front end (docs/laser-slam.md, "Local matching"): before a node's pose enters the
// graph, its scan is matched against the local map, the points of the nodes just before it at
// their graph poses, as Cartographer's local SLAM matches a scan against its active submaps. A
// correlative search (exact, branch and bound) in a window sized by the uncertainty of the EKF's
// step, the sub-cell refinement of correlative_matcher.h, and then a fusion with the EKF's step:
// the match is only as sure as the curvature of the score around it says (Laplace), so along a
// corridor without ends, where the score is flat, the EKF's step decides, and across it the
// walls do.

#include <optional>

#include <Eigen/Core>

#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct LocalMatchSettings {
  double grid_resolution = 0.05;
  double grid_sigma = 0.05;
  double min_score = 0.3;  // below it the match is not used (the map says too little)
  // Scan points per independent observation: neighbouring returns on one wall share its
  // roughness and the range bias, so they are not independent measurements of the pose.
  double points_per_observation = 4.0;
  // A best pose on the window's edge in x or y gives no translation (LocalMatchResult).
  bool ignore_edge_translation = false;
};

struct LocalMatchResult {
  Pose2 pose;                 // the fused pose of the query's frame in the local map's frame
  Eigen::Matrix3d covariance;  // of `pose` (x, y, theta)
  Pose2 matched;              // the match alone
  double score = 0.0;         // at `matched`
  // What the match alone knows (MatchInformation); without x and y when the best pose lay on
  // the window's edge and the settings say so.
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  // The best lattice pose lay on the window's edge in x or y: a score still rising beyond the
  // window says nothing of where the walls are best met (in the simulator's corridors such
  // matches were 12-21 cm off, ten times the others, each claiming 2-3 cm).
  bool at_window_edge = false;
  bool at_heading_edge = false;  // the best lattice heading was the window's first or last
};

// The best pose of `query` (its own frame) in `local_map` (points in the map's frame) within
// `window` of `prior`, fused with `prior` (covariance `prior_covariance`); nullopt when the local
// map is empty or no pose scores min_score.
std::optional<LocalMatchResult> MatchLocally(const PointCloud& local_map, const PointCloud& query,
                                             const Pose2& prior,
                                             const Eigen::Matrix3d& prior_covariance,
                                             const SearchWindow& window,
                                             const LocalMatchSettings& settings);

// Sets match->pose and ->covariance: the Gaussian fusion of match->matched (information
// match->information) with `prior` (covariance `prior_covariance`).
void FuseWithPrior(const Pose2& prior, const Eigen::Matrix3d& prior_covariance,
                   LocalMatchResult* match);

// The information (inverse covariance) a match at `pose` carries: the negative Hessian of the
// log-likelihood, taken as `observations` times the score's, by central differences of one cell
// and the rotation that moves the cloud's mean point by one cell; negative curvature is dropped.
Eigen::Matrix3d MatchInformation(const LikelihoodGrid& grid, const PointCloud& points,
                                 const Pose2& pose, double observations);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LOCAL_MATCHER_H_

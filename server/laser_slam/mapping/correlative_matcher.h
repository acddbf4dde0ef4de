#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_

// Scan-to-map matching by exhaustive correlative search made fast with branch and bound over a
// max-pooled pyramid (Olson 2009; Hess et al. 2016, section V): the best pose of a point cloud in
// a likelihood grid within a window, found exactly at the grid's resolution and the angular step
// the cloud's extent needs, then refined below a cell by bilinear interpolation.

#include <optional>

#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct SearchWindow {
  double xy = 1.0;     // +- metres around the initial pose, in x and y
  double theta = 0.3;  // +- radians
};

struct GridMatch {
  Pose2 pose;          // of the cloud's frame in the grid frame
  double score = 0.0;  // mean likelihood of the points at `pose`, 0..1
  // The same at the best pose on the grid's lattice, before refinement below a cell: what
  // FindRival's scores compare with (they are not refined either).
  double lattice_score = 0.0;
  long candidates = 0;  // scored (for the cost report)
};

// The best pose with score >= min_score, or nullopt. `points` in their own frame.
std::optional<GridMatch> MatchInWindow(const SearchPyramid& target, const PointCloud& points,
                                       const Pose2& initial, const SearchWindow& window,
                                       double min_score);

// A rival of the match at `best`: some pose in the same window whose points lie on average
// (root mean square) more than `exclusion` metres from where `best` puts them and that scores at
// least `min_score` on the grid's lattice (not refined: compare with GridMatch::lattice_score), or nullopt when there is none. A
// decision, not a search: it stops at the first such pose, so its score is not the second-best.
// A closure whose rival scores nearly as well could be either place (look-alike rooms, a
// corridor that slides along itself).
std::optional<GridMatch> FindRival(const SearchPyramid& target, const PointCloud& points,
                                   const Pose2& initial, const SearchWindow& window,
                                   const Pose2& best, double exclusion, double min_score);

// Whether the score stays at least `ratio` times its value at `a` at every quarter of the way from
// pose `a` to pose `b` (interpolated in x, y and heading): one ridge (a corridor that slides along
// itself) rather than two peaks (two places alike, with a valley between them).
bool OnOneRidge(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& a,
                const Pose2& b, double ratio);

// Mean likelihood (0..1) of `points` placed at `pose`, interpolated.
double ScoreAt(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& pose);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_

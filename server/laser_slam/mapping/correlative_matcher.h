#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_

// Scan-to-map matching by exhaustive correlative search made fast with branch and bound over a
// max-pooled pyramid (Olson 2009; Hess et al. 2016, section V): the best pose of a point cloud in
// a likelihood grid within a window, found exactly at the grid's resolution and the angular step
// the cloud's extent needs, then refined below a cell by bilinear interpolation.

#include <cstdint>
#include <functional>
#include <memory>
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
  // MatchInWindow: the best lattice pose lies on the window's outer ring of cells in x or y, so
  // the cells beyond it, which may score higher still, were not scored: no maximum was found.
  bool at_window_edge = false;
  // MatchInWindow: the best lattice heading is the window's first or last (and the window is
  // less than a full turn), so headings beyond it were not scored.
  bool at_heading_edge = false;
};

// A branch-and-bound search that stops once it has spent a budget of work and resumes where it
// stopped, so that a search over a whole map can be spread over several scans (the localizer's
// global search, localizer.h). Run to the end it answers exactly what MatchInWindow's lattice
// search (or FindRival's decision) answers: the same candidates in the same order.
class BranchAndBoundSearch {
 public:
  // Which lattice poses may be the answer (empty: any); asked only of leaves.
  using Allowed = std::function<bool(const Pose2&)>;
  // The best pose of `points` (their own frame) in `window` around `initial` whose lattice score
  // is at least `min_score` and that `allowed` accepts; with `first_only` any such pose (a
  // decision: it stops at the first). `target` must outlive the search.
  BranchAndBoundSearch(const SearchPyramid& target, const PointCloud& points, const Pose2& initial,
                       const SearchWindow& window, double min_score, bool first_only = false,
                       Allowed allowed = nullptr);
  ~BranchAndBoundSearch();
  BranchAndBoundSearch(BranchAndBoundSearch&&) noexcept;
  BranchAndBoundSearch& operator=(BranchAndBoundSearch&&) noexcept;

  // Goes on until the search is over or about `budget` more cell reads (one per point of every
  // candidate scored) are spent; true once it is over. The work between two checks of the budget
  // is one heading of the coarsest level or one candidate's children, so a call overruns its
  // budget by at most that.
  bool Resume(std::int64_t budget);
  bool done() const;
  // Once done: the pose found on the lattice (score = lattice_score, not refined), or nullopt.
  std::optional<GridMatch> result() const;
  std::int64_t reads() const;  // cell reads spent so far
  double angular_step() const;  // rad between the headings searched

 private:
  struct State;
  std::unique_ptr<State> state_;
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

// FindRival's two questions in one search: the first rival beyond `far_exclusion` (as FindRival
// with far_exclusion answers) and the first beyond `near_exclusion` (as FindRival with
// near_exclusion < far_exclusion answers), at the cost of one search, and of less when there is
// a far one (the search stops there).
struct Rivals {
  std::optional<Pose2> near;  // nullopt: no rival beyond near_exclusion
  std::optional<Pose2> far;   // nullopt: none beyond far_exclusion
};
Rivals FindRivals(const SearchPyramid& target, const PointCloud& points, const Pose2& initial,
                  const SearchWindow& window, const Pose2& best, double near_exclusion,
                  double far_exclusion, double min_score);

// Whether the score stays at least `ratio` times its value at `a` at every quarter of the way from
// pose `a` to pose `b` (interpolated in x, y and heading): one ridge (a corridor that slides along
// itself) rather than two peaks (two places alike, with a valley between them).
bool OnOneRidge(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& a,
                const Pose2& b, double ratio);

// Mean likelihood (0..1) of `points` placed at `pose`, interpolated.
double ScoreAt(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& pose);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_CORRELATIVE_MATCHER_H_

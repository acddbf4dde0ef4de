#include "server/laser_slam/mapping/correlative_matcher.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

namespace waymark::laser_slam {
namespace {

// The cloud rotated by one candidate angle, as base-grid cell indices at zero offset.
struct RotatedCloud {
  double theta = 0.0;
  std::vector<Eigen::Vector2i> cells;
};

struct Candidate {
  int rotation = 0;
  int x = 0;  // offset in cells
  int y = 0;
  double score = 0.0;  // upper bound at its level, 0..1
};

double LevelScore(const SearchPyramid& pyramid, int level, const RotatedCloud& cloud, int ox,
                  int oy) {
  long sum = 0;
  for (const Eigen::Vector2i& c : cloud.cells) sum += pyramid.At(level, c.x() + ox, c.y() + oy);
  return static_cast<double>(sum) / (255.0 * static_cast<double>(cloud.cells.size()));
}

}  // namespace

double ScoreAt(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& pose) {
  if (points.empty()) return 0.0;
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  double sum = 0.0;
  for (const Eigen::Vector2f& p : points) {
    sum += grid.Interpolate(pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y());
  }
  return sum / static_cast<double>(points.size());
}

namespace {

// The cloud at every candidate angle of the window, and the window in cells.
struct SearchSpace {
  std::vector<RotatedCloud> rotations;
  double step = 0.0;  // rad between rotations
  int half_cells = 0;
};

SearchSpace MakeSearchSpace(const LikelihoodGrid& grid, const PointCloud& points,
                            const Pose2& initial, const SearchWindow& window) {
  SearchSpace space;
  const double res = grid.resolution;
  double max_range = 0.0;
  for (const Eigen::Vector2f& p : points) max_range = std::max(max_range, double(p.norm()));
  // The angle that moves the farthest point by one cell.
  space.step =
      max_range > res ? std::acos(std::max(-1.0, 1.0 - res * res / (2 * max_range * max_range)))
                      : 0.1;
  const int half_rotations = std::min(static_cast<int>(std::ceil(window.theta / space.step)),
                                      static_cast<int>(std::ceil(M_PI / space.step)));
  space.rotations.reserve(2 * half_rotations + 1);
  for (int k = -half_rotations; k <= half_rotations; ++k) {
    RotatedCloud r;
    r.theta = initial.theta + k * space.step;
    const double c = std::cos(r.theta), s = std::sin(r.theta);
    r.cells.reserve(points.size());
    for (const Eigen::Vector2f& p : points) {
      const double wx = initial.x + c * p.x() - s * p.y();
      const double wy = initial.y + s * p.x() + c * p.y();
      r.cells.emplace_back(static_cast<int>(std::floor((wx - grid.origin.x()) / res)),
                           static_cast<int>(std::floor((wy - grid.origin.y()) / res)));
    }
    space.rotations.push_back(std::move(r));
  }
  space.half_cells = static_cast<int>(std::ceil(window.xy / res));
  return space;
}

// Depth-first branch and bound over `space`: the best leaf (base-level candidate) that `allowed`
// accepts and that scores at least `min_score`; with `first_only`, any such leaf (a decision,
// not a search: it stops at the first). `candidates` counts the scored candidates.
template <typename Allowed>
std::optional<Candidate> BranchAndBound(const SearchPyramid& target, const SearchSpace& space,
                                        double min_score, bool first_only, Allowed allowed,
                                        long* candidates) {
  const int top = target.depth();
  const int top_width = 1 << top;
  const int half_cells = space.half_cells;
  double best = min_score;
  std::optional<Candidate> found;
  // Expand the most promising candidates first so that `best` rises quickly and prunes the rest.
  std::vector<Candidate> top_level;
  for (int r = 0; r < static_cast<int>(space.rotations.size()); ++r) {
    for (int x = -half_cells; x <= half_cells; x += top_width) {
      for (int y = -half_cells; y <= half_cells; y += top_width) {
        Candidate c{r, x, y, LevelScore(target, top, space.rotations[r], x, y)};
        ++*candidates;
        if (c.score >= best) top_level.push_back(c);
      }
    }
  }
  std::sort(top_level.begin(), top_level.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  struct Frame {
    Candidate candidate;
    int level;
  };
  std::vector<Frame> stack;
  for (auto it = top_level.rbegin(); it != top_level.rend(); ++it) stack.push_back({*it, top});
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    if (f.candidate.score < best || (found && f.candidate.score <= best)) continue;
    if (f.level == 0) {
      if (!allowed(f.candidate)) continue;
      best = f.candidate.score;
      found = f.candidate;
      if (first_only) break;
      continue;
    }
    const int half = 1 << (f.level - 1);
    std::vector<Candidate> children;
    for (int dx : {0, half}) {
      for (int dy : {0, half}) {
        const int x = f.candidate.x + dx, y = f.candidate.y + dy;
        if (x > half_cells || y > half_cells) continue;
        Candidate c{f.candidate.rotation, x, y,
                    LevelScore(target, f.level - 1, space.rotations[f.candidate.rotation], x, y)};
        ++*candidates;
        if (c.score >= best) children.push_back(c);
      }
    }
    std::sort(children.begin(), children.end(),
              [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    for (const Candidate& c : children) stack.push_back({c, f.level - 1});
  }
  return found;
}

Pose2 CandidatePose(const SearchSpace& space, const Pose2& initial, double res,
                    const Candidate& c) {
  return Pose2{initial.x + c.x * res, initial.y + c.y * res, space.rotations[c.rotation].theta};
}

}  // namespace

bool OnOneRidge(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& a,
                const Pose2& b, double ratio) {
  const double at_a = ScoreAt(grid, points, a);
  const double turn = std::remainder(b.theta - a.theta, 2 * M_PI);
  for (double f : {0.25, 0.5, 0.75}) {
    const Pose2 between{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), a.theta + f * turn};
    if (ScoreAt(grid, points, between) < ratio * at_a) return false;
  }
  return true;
}

std::optional<GridMatch> FindRival(const SearchPyramid& target, const PointCloud& points,
                                   const Pose2& initial, const SearchWindow& window,
                                   const Pose2& best, double exclusion, double min_score) {
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return std::nullopt;
  // Mean squared displacement of the points between `best` and a candidate pose q, in closed
  // form from the points' centroid and mean squared norm: |d|^2 + 2 d.(A m) + 2 (1 - cos a) n,
  // with d the translation difference, A = R(q) - R(best), m the centroid, n the mean |p|^2.
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double mean_norm2 = 0.0;
  for (const Eigen::Vector2f& p : points) {
    centroid += p.cast<double>();
    mean_norm2 += p.cast<double>().squaredNorm();
  }
  centroid /= static_cast<double>(points.size());
  mean_norm2 /= static_cast<double>(points.size());
  const SearchSpace space = MakeSearchSpace(grid, points, initial, window);
  const double res = grid.resolution;
  const Eigen::Matrix2d best_rotation = Eigen::Rotation2Dd(best.theta).toRotationMatrix();
  const auto outside = [&](const Candidate& c) {
    const Pose2 q = CandidatePose(space, initial, res, c);
    const Eigen::Vector2d d(q.x - best.x, q.y - best.y);
    const Eigen::Matrix2d a = Eigen::Rotation2Dd(q.theta).toRotationMatrix() - best_rotation;
    const double msd = d.squaredNorm() + 2.0 * d.dot(a * centroid) +
                       2.0 * (1.0 - std::cos(q.theta - best.theta)) * mean_norm2;
    return msd > exclusion * exclusion;
  };
  GridMatch result;
  const std::optional<Candidate> rival =
      BranchAndBound(target, space, min_score, /*first_only=*/true, outside, &result.candidates);
  if (!rival) return std::nullopt;
  result.pose = CandidatePose(space, initial, res, *rival);
  result.score = rival->score;
  return result;
}

std::optional<GridMatch> MatchInWindow(const SearchPyramid& target, const PointCloud& points,
                                       const Pose2& initial, const SearchWindow& window,
                                       double min_score) {
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return std::nullopt;
  const double res = grid.resolution;
  const SearchSpace space = MakeSearchSpace(grid, points, initial, window);
  const double step = space.step;
  GridMatch result;
  const std::optional<Candidate> found = BranchAndBound(
      target, space, min_score, /*first_only=*/false, [](const Candidate&) { return true; },
      &result.candidates);
  if (!found) return std::nullopt;
  const Candidate& best_candidate = *found;
  result.lattice_score = best_candidate.score;

  // Below a cell: the discrete optimum refined on the interpolated field, in a small grid of
  // sub-cell shifts and sub-step turns around it.
  Pose2 pose = CandidatePose(space, initial, res, best_candidate);
  double score = ScoreAt(grid, points, pose);
  for (double scale : {0.5, 0.25}) {
    const Pose2 centre = pose;
    for (int i = -2; i <= 2; ++i) {
      for (int j = -2; j <= 2; ++j) {
        for (int k = -2; k <= 2; ++k) {
          const Pose2 p{centre.x + i * scale * res / 2, centre.y + j * scale * res / 2,
                        centre.theta + k * scale * step / 2};
          const double s = ScoreAt(grid, points, p);
          if (s > score) {
            score = s;
            pose = p;
          }
        }
      }
    }
  }
  result.pose = pose;
  result.pose.theta = std::remainder(pose.theta, 2 * M_PI);
  result.score = score;
  return result;
}

}  // namespace waymark::laser_slam

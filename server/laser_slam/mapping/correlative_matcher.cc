#include "server/laser_slam/mapping/correlative_matcher.h"

#include <algorithm>
#include <cmath>
#include <vector>

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

std::optional<GridMatch> MatchInWindow(const SearchPyramid& target, const PointCloud& points,
                                       const Pose2& initial, const SearchWindow& window,
                                       double min_score) {
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return std::nullopt;
  const double res = grid.resolution;
  double max_range = 0.0;
  for (const Eigen::Vector2f& p : points) max_range = std::max(max_range, double(p.norm()));
  // The angle that moves the farthest point by one cell.
  const double step =
      max_range > res ? std::acos(std::max(-1.0, 1.0 - res * res / (2 * max_range * max_range)))
                      : 0.1;
  const int half_rotations = std::min(static_cast<int>(std::ceil(window.theta / step)),
                                      static_cast<int>(std::ceil(M_PI / step)));
  std::vector<RotatedCloud> rotations;
  rotations.reserve(2 * half_rotations + 1);
  for (int k = -half_rotations; k <= half_rotations; ++k) {
    RotatedCloud r;
    r.theta = initial.theta + k * step;
    const double c = std::cos(r.theta), s = std::sin(r.theta);
    r.cells.reserve(points.size());
    for (const Eigen::Vector2f& p : points) {
      const double wx = initial.x + c * p.x() - s * p.y();
      const double wy = initial.y + s * p.x() + c * p.y();
      r.cells.emplace_back(static_cast<int>(std::floor((wx - grid.origin.x()) / res)),
                           static_cast<int>(std::floor((wy - grid.origin.y()) / res)));
    }
    rotations.push_back(std::move(r));
  }
  const int half_cells = static_cast<int>(std::ceil(window.xy / res));
  const int top = target.depth();
  const int top_width = 1 << top;

  GridMatch result;
  double best = min_score;
  bool found = false;
  Candidate best_candidate;
  // Depth-first branch and bound: expand the most promising candidates first so that `best`
  // rises quickly and prunes the rest.
  std::vector<Candidate> top_level;
  for (int r = 0; r < static_cast<int>(rotations.size()); ++r) {
    for (int x = -half_cells; x <= half_cells; x += top_width) {
      for (int y = -half_cells; y <= half_cells; y += top_width) {
        Candidate c{r, x, y, LevelScore(target, top, rotations[r], x, y)};
        ++result.candidates;
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
      best = f.candidate.score;
      best_candidate = f.candidate;
      found = true;
      continue;
    }
    const int half = 1 << (f.level - 1);
    std::vector<Candidate> children;
    for (int dx : {0, half}) {
      for (int dy : {0, half}) {
        const int x = f.candidate.x + dx, y = f.candidate.y + dy;
        if (x > half_cells || y > half_cells) continue;
        Candidate c{f.candidate.rotation, x, y,
                    LevelScore(target, f.level - 1, rotations[f.candidate.rotation], x, y)};
        ++result.candidates;
        if (c.score >= best) children.push_back(c);
      }
    }
    std::sort(children.begin(), children.end(),
              [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    for (const Candidate& c : children) stack.push_back({c, f.level - 1});
  }
  if (!found) return std::nullopt;

  // Below a cell: the discrete optimum refined on the interpolated field, in a small grid of
  // sub-cell shifts and sub-step turns around it.
  Pose2 pose{initial.x + best_candidate.x * res, initial.y + best_candidate.y * res,
             rotations[best_candidate.rotation].theta};
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

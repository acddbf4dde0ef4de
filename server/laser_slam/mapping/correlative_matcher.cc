#include "server/laser_slam/mapping/correlative_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
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

// The window in cells and headings; the cloud at each heading is made as the search reaches it.
struct SearchSpace {
  std::vector<RotatedCloud> rotations;
  double step = 0.0;  // rad between rotations
  int half_rotations = 0;
  int half_cells = 0;
};

SearchSpace MakeSearchSpace(const LikelihoodGrid& grid, const PointCloud& points,
                            const SearchWindow& window) {
  SearchSpace space;
  const double res = grid.resolution;
  double max_range = 0.0;
  for (const Eigen::Vector2f& p : points) max_range = std::max(max_range, double(p.norm()));
  // The angle that moves the farthest point by one cell.
  space.step =
      max_range > res ? std::acos(std::max(-1.0, 1.0 - res * res / (2 * max_range * max_range)))
                      : 0.1;
  space.half_rotations = std::min(static_cast<int>(std::ceil(window.theta / space.step)),
                                  static_cast<int>(std::ceil(M_PI / space.step)));
  space.rotations.reserve(2 * space.half_rotations + 1);
  space.half_cells = static_cast<int>(std::ceil(window.xy / res));
  return space;
}

// The cloud at rotation index `k` (-half_rotations .. half_rotations), as base-grid cells.
RotatedCloud Rotate(const LikelihoodGrid& grid, const PointCloud& points, const Pose2& initial,
                    double step, int k) {
  RotatedCloud r;
  r.theta = initial.theta + k * step;
  const double c = std::cos(r.theta), s = std::sin(r.theta);
  r.cells.reserve(points.size());
  for (const Eigen::Vector2f& p : points) {
    const double wx = initial.x + c * p.x() - s * p.y();
    const double wy = initial.y + s * p.x() + c * p.y();
    r.cells.emplace_back(static_cast<int>(std::floor((wx - grid.origin.x()) / grid.resolution)),
                         static_cast<int>(std::floor((wy - grid.origin.y()) / grid.resolution)));
  }
  return r;
}

Pose2 CandidatePose(const SearchSpace& space, const Pose2& initial, double res,
                    const Candidate& c) {
  return Pose2{initial.x + c.x * res, initial.y + c.y * res, space.rotations[c.rotation].theta};
}

struct Frame {
  Candidate candidate;
  int level = 0;
};

}  // namespace

// Depth-first branch and bound over the search space: the coarsest level is scored heading by
// heading, sorted, then expanded most promising first so that `best` rises quickly and prunes
// the rest.
struct BranchAndBoundSearch::State {
  const SearchPyramid* target = nullptr;
  PointCloud points;
  Pose2 initial;
  SearchSpace space;
  bool first_only = false;
  Allowed allowed;
  double best = 0.0;  // the pruning bound: min_score, then the best leaf's score
  std::optional<Candidate> found;
  std::vector<Candidate> top_level;  // scored so far (headings before next_rotation)
  bool top_level_done = false;
  std::vector<Frame> stack;
  bool done = false;
  long candidates = 0;
  std::int64_t reads = 0;

  // Scores one candidate (its cloud's cells summed at `level`), counting the reads.
  double Score(int level, int rotation, int x, int y) {
    ++candidates;
    reads += static_cast<std::int64_t>(points.size());
    return LevelScore(*target, level, space.rotations[rotation], x, y);
  }
};

BranchAndBoundSearch::BranchAndBoundSearch(const SearchPyramid& target, const PointCloud& points,
                                           const Pose2& initial, const SearchWindow& window,
                                           double min_score, bool first_only, Allowed allowed)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.target = &target;
  s.points = points;
  s.initial = initial;
  s.first_only = first_only;
  s.allowed = std::move(allowed);
  s.best = min_score;
  s.done = points.empty() || target.base().empty();
  if (!s.done) s.space = MakeSearchSpace(target.base(), points, window);
}

BranchAndBoundSearch::~BranchAndBoundSearch() = default;
BranchAndBoundSearch::BranchAndBoundSearch(BranchAndBoundSearch&&) noexcept = default;
BranchAndBoundSearch& BranchAndBoundSearch::operator=(BranchAndBoundSearch&&) noexcept = default;

bool BranchAndBoundSearch::Resume(std::int64_t budget) {
  State& s = *state_;
  if (s.done) return true;
  constexpr std::int64_t kUnbounded = std::numeric_limits<std::int64_t>::max();
  const std::int64_t limit = budget >= kUnbounded - s.reads ? kUnbounded : s.reads + budget;
  const SearchPyramid& target = *s.target;
  const int top = target.depth();
  const int top_width = 1 << top;
  const int half_cells = s.space.half_cells;
  if (!s.top_level_done) {
    while (static_cast<int>(s.space.rotations.size()) < 2 * s.space.half_rotations + 1) {
      if (s.reads >= limit) return false;
      const int r = static_cast<int>(s.space.rotations.size());
      s.space.rotations.push_back(Rotate(target.base(), s.points, s.initial, s.space.step,
                                         r - s.space.half_rotations));
      for (int x = -half_cells; x <= half_cells; x += top_width) {
        for (int y = -half_cells; y <= half_cells; y += top_width) {
          Candidate c{r, x, y, s.Score(top, r, x, y)};
          if (c.score >= s.best) s.top_level.push_back(c);
        }
      }
    }
    std::sort(s.top_level.begin(), s.top_level.end(),
              [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
    s.stack.reserve(s.top_level.size());
    for (auto it = s.top_level.rbegin(); it != s.top_level.rend(); ++it) {
      s.stack.push_back({*it, top});
    }
    s.top_level = {};
    s.top_level_done = true;
  }
  const double res = target.base().resolution;
  while (!s.stack.empty()) {
    if (s.reads >= limit) return false;
    const Frame f = s.stack.back();
    s.stack.pop_back();
    if (f.candidate.score < s.best || (s.found && f.candidate.score <= s.best)) continue;
    if (f.level == 0) {
      if (s.allowed && !s.allowed(CandidatePose(s.space, s.initial, res, f.candidate))) continue;
      s.best = f.candidate.score;
      s.found = f.candidate;
      if (s.first_only) break;
      continue;
    }
    const int half = 1 << (f.level - 1);
    Candidate children[4];
    int count = 0;
    for (int dx : {0, half}) {
      for (int dy : {0, half}) {
        const int x = f.candidate.x + dx, y = f.candidate.y + dy;
        if (x > half_cells || y > half_cells) continue;
        Candidate c{f.candidate.rotation, x, y, s.Score(f.level - 1, f.candidate.rotation, x, y)};
        if (c.score >= s.best) children[count++] = c;
      }
    }
    // Ascending, equal scores kept in order (what std::sort's insertion sort does for so few, so
    // the search visits candidates in the order it always did).
    for (int i = 1; i < count; ++i) {
      for (int j = i; j > 0 && children[j].score < children[j - 1].score; --j) {
        std::swap(children[j], children[j - 1]);
      }
    }
    for (int i = 0; i < count; ++i) s.stack.push_back({children[i], f.level - 1});
  }
  s.stack = {};
  s.done = true;
  return true;
}

bool BranchAndBoundSearch::done() const { return state_->done; }
std::int64_t BranchAndBoundSearch::reads() const { return state_->reads; }
double BranchAndBoundSearch::angular_step() const { return state_->space.step; }

std::optional<GridMatch> BranchAndBoundSearch::result() const {
  const State& s = *state_;
  if (!s.done || !s.found) return std::nullopt;
  GridMatch match;
  match.pose = CandidatePose(s.space, s.initial, s.target->base().resolution, *s.found);
  match.score = s.found->score;
  match.lattice_score = s.found->score;
  match.candidates = s.candidates;
  return match;
}

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
  const Eigen::Matrix2d best_rotation = Eigen::Rotation2Dd(best.theta).toRotationMatrix();
  const auto outside = [&](const Pose2& q) {
    const Eigen::Vector2d d(q.x - best.x, q.y - best.y);
    const Eigen::Matrix2d a = Eigen::Rotation2Dd(q.theta).toRotationMatrix() - best_rotation;
    const double msd = d.squaredNorm() + 2.0 * d.dot(a * centroid) +
                       2.0 * (1.0 - std::cos(q.theta - best.theta)) * mean_norm2;
    return msd > exclusion * exclusion;
  };
  BranchAndBoundSearch search(target, points, initial, window, min_score, /*first_only=*/true,
                              outside);
  search.Resume(std::numeric_limits<std::int64_t>::max());
  return search.result();
}

std::optional<GridMatch> MatchInWindow(const SearchPyramid& target, const PointCloud& points,
                                       const Pose2& initial, const SearchWindow& window,
                                       double min_score) {
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return std::nullopt;
  const double res = grid.resolution;
  BranchAndBoundSearch search(target, points, initial, window, min_score);
  search.Resume(std::numeric_limits<std::int64_t>::max());
  const std::optional<GridMatch> found = search.result();
  if (!found) return std::nullopt;
  const double step = search.angular_step();
  GridMatch result;
  result.candidates = found->candidates;
  result.lattice_score = found->lattice_score;

  // Below a cell: the discrete optimum refined on the interpolated field, in a small grid of
  // sub-cell shifts and sub-step turns around it.
  Pose2 pose = found->pose;
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

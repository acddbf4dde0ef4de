#include "server/laser_slam/mapping/correlative_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

// The cloud rotated by one candidate angle, as base-grid cell indices at zero offset, with their
// bounding box, and as offsets in the pyramid's storage (y * stride + x, the same at every level).
struct RotatedCloud {
  double theta = 0.0;
  std::vector<Eigen::Vector2i> cells;
  std::vector<std::int32_t> index;
  Eigen::Vector2i lo = Eigen::Vector2i::Zero();
  Eigen::Vector2i hi = Eigen::Vector2i::Zero();
};

struct Candidate {
  int rotation = 0;
  int x = 0;  // offset in cells
  int y = 0;
  double score = 0.0;  // upper bound at its level, 0..1
};

// The least sum of cell values (out of 255 per point, `n` points) whose score reaches `best`:
// every smaller sum scores below it, as LevelScore divides.
std::int64_t NeededSum(double best, size_t n) {
  const double k = 255.0 * static_cast<double>(n);
  const std::int64_t most = 255 * static_cast<std::int64_t>(n);
  if (!(best > 0.0)) return std::numeric_limits<std::int64_t>::min() / 2;
  if (best > 1.0) return most + 1;
  std::int64_t t = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::ceil(best * k)), 0,
                                            most + 1);
  while (t > 0 && static_cast<double>(t - 1) / k >= best) --t;
  while (t <= most && static_cast<double>(t) / k < best) ++t;
  return t;
}

// The cloud's mean cell value (0..1) at `level` shifted by (ox, oy) cells. Gives up as soon as
// even 255 under every point left could not bring the sum to `needed`, returning that bound
// (below the score `needed` stands for): branch and bound drops such a candidate anyway.
double LevelScore(const SearchPyramid& pyramid, int level, const RotatedCloud& cloud, int ox,
                  int oy, std::int64_t needed) {
  const SearchPyramid::LevelView l = pyramid.level(level);
  const int n = static_cast<int>(cloud.cells.size());
  const double k = 255.0 * static_cast<double>(n);
  const int dx = ox + l.offset_x, dy = oy + l.offset_y;
  const Eigen::Vector2i* cells = cloud.cells.data();
  // Inside the level everywhere: no bounds to check.
  const bool inside = cloud.lo.x() + dx >= 0 && cloud.lo.y() + dy >= 0 &&
                      cloud.hi.x() + dx < l.width && cloud.hi.y() + dy < l.height;
  const std::ptrdiff_t shift = static_cast<std::ptrdiff_t>(dy) * l.width + dx;
  const std::int32_t* index = cloud.index.data();
  std::int64_t sum = 0;
  std::int64_t left = 255 * static_cast<std::int64_t>(n);
  constexpr int kChunk = 32;
  for (int i = 0; i < n; i += kChunk) {
    const int end = std::min(n, i + kChunk);
    if (inside) {
      for (int j = i; j < end; ++j) sum += l.cells[shift + index[j]];
    } else {
      for (int j = i; j < end; ++j) {
        const unsigned x = static_cast<unsigned>(cells[j].x() + dx);
        const unsigned y = static_cast<unsigned>(cells[j].y() + dy);
        if (x < static_cast<unsigned>(l.width) && y < static_cast<unsigned>(l.height)) {
          sum += l.cells[static_cast<size_t>(y) * l.width + x];
        }
      }
    }
    left -= 255 * static_cast<std::int64_t>(end - i);
    if (sum + left < needed) return static_cast<double>(sum + left) / k;
  }
  return static_cast<double>(sum) / k;
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
RotatedCloud Rotate(const SearchPyramid& target, const PointCloud& points, const Pose2& initial,
                    double step, int k) {
  const LikelihoodGrid& grid = target.base();
  const std::int64_t stride = target.level(0).width;
  RotatedCloud r;
  r.theta = initial.theta + k * step;
  const double c = std::cos(r.theta), s = std::sin(r.theta);
  r.cells.reserve(points.size());
  r.index.reserve(points.size());
  for (const Eigen::Vector2f& p : points) {
    const double wx = initial.x + c * p.x() - s * p.y();
    const double wy = initial.y + s * p.x() + c * p.y();
    r.cells.emplace_back(static_cast<int>(std::floor((wx - grid.origin.x()) / grid.resolution)),
                         static_cast<int>(std::floor((wy - grid.origin.y()) / grid.resolution)));
    // Wraps for a point far off the grid; only read when the whole cloud is on it.
    r.index.push_back(static_cast<std::int32_t>(r.cells.back().y() * stride + r.cells.back().x()));
  }
  if (!r.cells.empty()) {
    r.lo = r.hi = r.cells.front();
    for (const Eigen::Vector2i& c : r.cells) {
      r.lo = r.lo.cwiseMin(c);
      r.hi = r.hi.cwiseMax(c);
    }
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
  std::int64_t needed = 0;  // NeededSum(best, points)
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
    return LevelScore(*target, level, space.rotations[rotation], x, y, needed);
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
  s.needed = NeededSum(min_score, points.size());
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
      s.space.rotations.push_back(Rotate(target, s.points, s.initial, s.space.step,
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
      s.needed = NeededSum(s.best, s.points.size());
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

namespace {

// Whether pose q puts `points` on average (root mean square) more than `distance` from where
// `best` puts them, in closed form from the points' centroid and mean squared norm:
// msd = |d|^2 + 2 d.(A m) + 2 (1 - cos a) n, with d the translation difference,
// A = R(q) - R(best), m the centroid, n the mean |p|^2.
class Displacement {
 public:
  Displacement(const PointCloud& points, const Pose2& best) : best_(best) {
    for (const Eigen::Vector2f& p : points) {
      centroid_ += p.cast<double>();
      mean_norm2_ += p.cast<double>().squaredNorm();
    }
    centroid_ /= static_cast<double>(points.size());
    mean_norm2_ /= static_cast<double>(points.size());
    best_rotation_ = Eigen::Rotation2Dd(best.theta).toRotationMatrix();
  }
  bool Beyond(const Pose2& q, double distance) const {
    const Eigen::Vector2d d(q.x - best_.x, q.y - best_.y);
    const Eigen::Matrix2d a = Eigen::Rotation2Dd(q.theta).toRotationMatrix() - best_rotation_;
    const double msd = d.squaredNorm() + 2.0 * d.dot(a * centroid_) +
                       2.0 * (1.0 - std::cos(q.theta - best_.theta)) * mean_norm2_;
    return msd > distance * distance;
  }

 private:
  Pose2 best_;
  Eigen::Vector2d centroid_ = Eigen::Vector2d::Zero();
  double mean_norm2_ = 0.0;
  Eigen::Matrix2d best_rotation_;
};

}  // namespace

std::optional<GridMatch> FindRival(const SearchPyramid& target, const PointCloud& points,
                                   const Pose2& initial, const SearchWindow& window,
                                   const Pose2& best, double exclusion, double min_score) {
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return std::nullopt;
  const Displacement displacement(points, best);
  BranchAndBoundSearch search(
      target, points, initial, window, min_score, /*first_only=*/true,
      [&](const Pose2& q) { return displacement.Beyond(q, exclusion); });
  search.Resume(std::numeric_limits<std::int64_t>::max());
  return search.result();
}

Rivals FindRivals(const SearchPyramid& target, const PointCloud& points, const Pose2& initial,
                  const SearchWindow& window, const Pose2& best, double near_exclusion,
                  double far_exclusion, double min_score) {
  Rivals rivals;
  const LikelihoodGrid& grid = target.base();
  if (points.empty() || grid.empty()) return rivals;
  const Displacement displacement(points, best);
  // Leaves that are not allowed leave the bound where it is, so the search visits the leaves in
  // the order either FindRival would: the first beyond near_exclusion is the near one's answer.
  BranchAndBoundSearch search(target, points, initial, window, min_score, /*first_only=*/true,
                              [&](const Pose2& q) {
                                if (displacement.Beyond(q, far_exclusion)) return true;
                                if (!rivals.near && displacement.Beyond(q, near_exclusion)) {
                                  rivals.near = q;
                                }
                                return false;
                              });
  search.Resume(std::numeric_limits<std::int64_t>::max());
  if (const std::optional<GridMatch> far = search.result()) {
    rivals.far = far->pose;
    if (!rivals.near) rivals.near = far->pose;
  }
  return rivals;
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
  const long half_cells = static_cast<long>(std::ceil(window.xy / res));
  const long half_rotations = static_cast<long>(std::ceil(window.theta / step));
  result.at_heading_edge =
      window.theta < M_PI &&
      std::labs(std::lround(NormalizeAngle(found->pose.theta - initial.theta) / step)) >=
          half_rotations;
  result.at_window_edge = std::labs(std::lround((found->pose.x - initial.x) / res)) >= half_cells ||
                          std::labs(std::lround((found->pose.y - initial.y) / res)) >= half_cells;

  // Below a cell: the discrete optimum refined on the interpolated field, in a small grid of
  // sub-cell shifts and sub-step turns around it (the first best in (i, j, k) order), at two
  // scales. The cloud is turned once per heading. A point's bilinear value at the five shifts in
  // y is interpolated between the same few rows (the shifts span one cell at most), so each row
  // is interpolated in x once per shift in x and shared by the five shifts in y: a third of the
  // cell reads of interpolating each pose alone, the same values up to rounding.
  Pose2 pose = found->pose;
  double score = ScoreAt(grid, points, pose);
  const size_t n = points.size();
  double scores[5][5][5];
  double sums[5][5];
  for (double scale : {0.5, 0.25}) {
    const Pose2 centre = pose;
    const double shift = scale * res / 2;
    for (int k = -2; k <= 2; ++k) {
      const double theta = centre.theta + k * scale * step / 2;
      const double c = std::cos(theta), s = std::sin(theta);
      for (auto& row : sums) std::fill(std::begin(row), std::end(row), 0.0);
      for (size_t m = 0; m < n; ++m) {
        const double px = points[m].x(), py = points[m].y();
        // As ScoreAt places the point, and Interpolate finds its cell; a shift is scale / 2 of
        // a cell (a binary fraction: no rounding in the steps).
        const double gx0 = (centre.x + c * px - s * py - grid.origin.x()) / res - 0.5;
        const double gy0 = (centre.y + s * px + c * py - grid.origin.y()) / res - 0.5;
        const double cells_per_shift = scale / 2;
        int cy[5];
        double fy[5];
        for (int j = 0; j < 5; ++j) {
          const double gy = gy0 + (j - 2) * cells_per_shift;
          cy[j] = static_cast<int>(std::floor(gy));
          fy[j] = gy - cy[j];
        }
        // The five shifts span 2 * scale <= 1 cell: cy[4] is cy[0] or the row above, and the
        // values read lie in rows cy[0] .. cy[0] + 2 at most.
        const int lo = cy[0];
        const int rows = cy[4] - lo + 2;
        for (int i = 0; i < 5; ++i) {
          const double gx = gx0 + (i - 2) * cells_per_shift;
          const int cx = static_cast<int>(std::floor(gx));
          const double fx = gx - cx;
          double across[3];  // the rows lo.. interpolated in x
          const int sx = cx - grid.x0, sy = lo - grid.y0;
          if (sx >= 0 && sy >= 0 && sx + 1 < grid.width && sy + rows - 1 < grid.height) {
            const std::uint8_t* at = grid.cells.data() + static_cast<size_t>(sy) * grid.width + sx;
            for (int r = 0; r < rows; ++r, at += grid.width) {
              across[r] = (1 - fx) * at[0] + fx * at[1];
            }
          } else {
            // At the grid's edge: cells outside read 0, as Bilinear reads them.
            for (int r = 0; r < rows; ++r) {
              across[r] = (1 - fx) * grid.At(cx, lo + r) + fx * grid.At(cx + 1, lo + r);
            }
          }
          for (int j = 0; j < 5; ++j) {
            const int r = cy[j] - lo;
            sums[i][j] += (1 - fy[j]) * across[r] + fy[j] * across[r + 1];
          }
        }
      }
      for (int i = 0; i < 5; ++i) {
        for (int j = 0; j < 5; ++j) {
          scores[i][j][k + 2] = sums[i][j] / (255.0 * static_cast<double>(n));
        }
      }
    }
    for (int i = -2; i <= 2; ++i) {
      for (int j = -2; j <= 2; ++j) {
        for (int k = -2; k <= 2; ++k) {
          if (scores[i + 2][j + 2][k + 2] > score) {
            score = scores[i + 2][j + 2][k + 2];
            pose = Pose2{centre.x + i * shift, centre.y + j * shift,
                         centre.theta + k * scale * step / 2};
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

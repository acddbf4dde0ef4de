#include "server/laser_slam/mapping/map_consistency.h"

#include "server/laser_slam/mapping/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::laser_slam {
namespace {

// The occupancy grid's evidence model (occupancy_grid.cc: a hit +0.85, a pass-through -0.2 in log
// odds) and map.yaml's trinary thresholds (occupied >= 0.65, free <= 0.196), so that "a wall" and
// "clearly free" mean what the exported map shows: a contradiction is a place where one submap's
// map would be drawn black and another's white.
constexpr double kHit = 0.85;
constexpr double kMiss = -0.2;
const double kOccupiedLogOdds = std::log(0.65 / 0.35);
const double kFreeLogOdds = std::log(0.196 / 0.804);

double LogOdds(int hits, int frees) { return kHit * hits + kMiss * frees; }

// The back end keeps returns within 12 m (MappingOptions::point_range): a submap turned by
// (a quarter cell / 12 m) moves its farthest point by a quarter cell.
constexpr double kReuseRange = 12.0;

// What one submap says about a cell (bits).
constexpr std::uint8_t kWall = 1;      // its own wall: min_hits, occupied by its evidence alone
constexpr std::uint8_t kWallNear = 2;  // a hit of it not drowned in pass-throughs within tolerance
constexpr std::uint8_t kFree = 4;      // clearly free by its evidence alone

// The map's cells: cell (x, y) is [x, x + 1) x [y, y + 1) times the resolution in the map frame,
// the same for every submap and every check (a view cast for one check stays valid for the next);
// `lo` and the size are where the current map's cells are, for indices and tiles.
struct CellFrame {
  double resolution = 0.1;
  Eigen::Vector2i lo = Eigen::Vector2i::Zero();
  int width = 0;
  int height = 0;

  Eigen::Vector2i CellOf(double x, double y) const {
    return {static_cast<int>(std::floor(x / resolution)),
            static_cast<int>(std::floor(y / resolution))};
  }
  Eigen::Vector2d CentreOf(int x, int y) const {
    return Eigen::Vector2d(x + 0.5, y + 0.5) * resolution;
  }
  // Index from 0 over the current map's cells, and back.
  std::int64_t Index(int x, int y) const {
    return static_cast<std::int64_t>(y - lo.y()) * width + (x - lo.x());
  }
  Eigen::Vector2i CellAt(std::int64_t index) const {
    return {static_cast<int>(index % width) + lo.x(), static_cast<int>(index / width) + lo.y()};
  }
};

// Square tiles of `size` metres: tile (i, j) is [i, i + 1) x [j, j + 1) times the size in the
// map frame, so a tile is the same area in every check.
Eigen::Vector2i AbsoluteTileOf(int x, int y, double resolution, double size) {
  return {static_cast<int>(std::floor(x * resolution / size)),
          static_cast<int>(std::floor(y * resolution / size))};
}

// One submap's view over the rectangle of cells [x0, x0 + width) x [y0, y0 + height) it covers:
// one byte of bits per cell, so every submap's view can be kept for the pairwise comparison.
struct SubmapView {
  int x0 = 0;
  int y0 = 0;
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> bits;
  std::vector<Eigen::Vector2i> walls;                   // its kWall cells, row by row
  std::vector<std::pair<Eigen::Vector2i, int>> points;  // its scan points per absolute tile
  std::uint64_t generation = 0;                         // new whenever the submap is cast again

  bool Contains(int x, int y) const {
    return x >= x0 && y >= y0 && x < x0 + width && y < y0 + height;
  }
  size_t Index(int x, int y) const {
    return static_cast<size_t>(y - y0) * width + static_cast<size_t>(x - x0);
  }
  std::uint8_t At(int x, int y) const { return Contains(x, y) ? bits[Index(x, y)] : 0; }
  bool Overlaps(const SubmapView& o) const {
    return x0 < o.x0 + o.width && o.x0 < x0 + width && y0 < o.y0 + o.height && o.y0 < y0 + height;
  }
};

// Calls free_cell(x, y) for every cell a ray from the node to each of its points crosses (its end
// cell excluded) and hit_cell(x, y) for the end cell (Bresenham, as occupancy_grid.cc draws).
template <typename FreeFn, typename HitFn>
void CastNode(const NodeView& node, const CellFrame& frame, FreeFn&& free_cell, HitFn&& hit_cell) {
  if (node.points == nullptr) return;
  const Eigen::Vector2i from = frame.CellOf(node.global.x, node.global.y);
  const double c = std::cos(node.global.theta), s = std::sin(node.global.theta);
  for (const Eigen::Vector2f& q : *node.points) {
    const Eigen::Vector2i to =
        frame.CellOf(node.global.x + c * q.x() - s * q.y(), node.global.y + s * q.x() + c * q.y());
    ForEachCellBefore(from, to, free_cell);
    hit_cell(to.x(), to.y());
  }
}

// The cells a run of nodes covers (positions and points), grown by `margin` cells.
SubmapView BoxOf(const std::vector<NodeView>& nodes, int first, int end, const CellFrame& frame,
                 int margin) {
  Eigen::Vector2i lo = Eigen::Vector2i::Constant(std::numeric_limits<int>::max());
  Eigen::Vector2i hi = Eigen::Vector2i::Constant(std::numeric_limits<int>::min());
  for (int i = first; i < end; ++i) {
    const NodeView& node = nodes[i];
    const auto extend = [&](double x, double y) {
      const Eigen::Vector2i cell = frame.CellOf(x, y);
      lo = lo.cwiseMin(cell);
      hi = hi.cwiseMax(cell);
    };
    extend(node.global.x, node.global.y);
    if (node.points == nullptr) continue;
    const double c = std::cos(node.global.theta), s = std::sin(node.global.theta);
    for (const Eigen::Vector2f& q : *node.points) {
      extend(node.global.x + c * q.x() - s * q.y(), node.global.y + s * q.x() + c * q.y());
    }
  }
  SubmapView view;
  view.x0 = lo.x() - margin;
  view.y0 = lo.y() - margin;
  view.width = hi.x() - lo.x() + 1 + 2 * margin;
  view.height = hi.y() - lo.y() + 1 + 2 * margin;
  view.bits.assign(static_cast<size_t>(view.width) * view.height, 0);
  return view;
}

// Nodes [first, end) cast alone and classified.
SubmapView ViewOf(const std::vector<NodeView>& nodes, int first, int end, const CellFrame& frame,
                  const MapConsistencyOptions& options, int radius) {
  SubmapView view = BoxOf(nodes, first, end, frame, radius);
  std::map<std::pair<int, int>, int> points;
  std::vector<std::uint16_t> hits(view.bits.size(), 0), frees(view.bits.size(), 0);
  const auto add = [](std::uint16_t& count) {
    if (count < std::numeric_limits<std::uint16_t>::max()) ++count;
  };
  for (int i = first; i < end; ++i) {
    CastNode(
        nodes[i], frame, [&](int x, int y) { add(frees[view.Index(x, y)]); },
        [&](int x, int y) {
          add(hits[view.Index(x, y)]);
          const Eigen::Vector2i t = AbsoluteTileOf(x, y, frame.resolution, options.tile_size);
          ++points[{t.x(), t.y()}];
        });
  }
  for (int y = view.y0; y < view.y0 + view.height; ++y) {
    for (int x = view.x0; x < view.x0 + view.width; ++x) {
      const size_t k = view.Index(x, y);
      const double log_odds = LogOdds(hits[k], frees[k]);
      if (frees[k] > 0 && log_odds <= kFreeLogOdds) view.bits[k] |= kFree;
      if (hits[k] >= options.min_hits && log_odds >= kOccupiedLogOdds) view.bits[k] |= kWall;
      // Any hit the submap's own rays do not wash out is a wall seen there, for confirming
      // another submap's wall: the disc of `radius` around it is "near a wall".
      if (hits[k] == 0 || log_odds <= kFreeLogOdds) continue;
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          if (dx * dx + dy * dy <= radius * radius)
            view.bits[view.Index(x + dx, y + dy)] |= kWallNear;
        }
      }
    }
  }
  for (int y = view.y0; y < view.y0 + view.height; ++y) {
    for (int x = view.x0; x < view.x0 + view.width; ++x) {
      if (view.bits[view.Index(x, y)] & kWall) view.walls.emplace_back(x, y);
    }
  }
  for (const auto& [tile, count] : points) {
    view.points.emplace_back(Eigen::Vector2i(tile.first, tile.second), count);
  }
  return view;
}

// The frame over every node and point, at the finest resolution at or above the asked one whose
// grid has at most max_cells cells (as occupancy_grid.h's ResolutionThatFits).
CellFrame FrameOf(const std::vector<NodeView>& nodes, const MapConsistencyOptions& options) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::max());
  Eigen::Vector2d hi = -lo;
  for (const NodeView& node : nodes) {
    lo = lo.cwiseMin(Eigen::Vector2d(node.global.x, node.global.y));
    hi = hi.cwiseMax(Eigen::Vector2d(node.global.x, node.global.y));
    if (node.points == nullptr) continue;
    const double c = std::cos(node.global.theta), s = std::sin(node.global.theta);
    for (const Eigen::Vector2f& q : *node.points) {
      const Eigen::Vector2d p(node.global.x + c * q.x() - s * q.y(),
                              node.global.y + s * q.x() + c * q.y());
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const auto cells_at = [&](double resolution) {
    const Eigen::Vector2d span = (hi - lo) / resolution + Eigen::Vector2d::Constant(2.0);
    return std::ceil(span.x()) * std::ceil(span.y());
  };
  CellFrame frame;
  frame.resolution = options.resolution;
  const double max_cells = static_cast<double>(options.max_cells);
  while (cells_at(frame.resolution) > max_cells) {
    frame.resolution =
        std::ceil(frame.resolution * std::sqrt(cells_at(frame.resolution) / max_cells) * 1000.0 +
                  1.0) /
        1000.0;
  }
  // A margin of two cells: a submap's view kept from an earlier check may lie up to a quarter
  // cell off its nodes' current poses.
  frame.lo = frame.CellOf(lo.x(), lo.y()) - Eigen::Vector2i::Constant(2);
  const Eigen::Vector2i top = frame.CellOf(hi.x(), hi.y()) + Eigen::Vector2i::Constant(2);
  frame.width = top.x() - frame.lo.x() + 1;
  frame.height = top.y() - frame.lo.y() + 1;
  return frame;
}

// Connected (8-neighbour) runs of cells (sorted unique indices): for each cell, its run's length,
// the longer side of the run's bounding box in cells. A wall is long and thin; a person, a chair
// or a car's corner is compact, however many cells it fills.
std::vector<int> RunLengths(const std::vector<std::int64_t>& cells, int width) {
  std::unordered_map<std::int64_t, int> position;
  position.reserve(cells.size() * 2);
  for (size_t i = 0; i < cells.size(); ++i) position[cells[i]] = static_cast<int>(i);
  std::vector<int> run(cells.size(), -1);
  std::vector<int> lengths;
  std::vector<int> stack;
  for (size_t start = 0; start < cells.size(); ++start) {
    if (run[start] >= 0) continue;
    const int id = static_cast<int>(lengths.size());
    std::int64_t min_x = width, max_x = -1, min_y = std::numeric_limits<std::int64_t>::max(),
                 max_y = -1;
    run[start] = id;
    stack.assign(1, static_cast<int>(start));
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      const std::int64_t x = cells[i] % width, y = cells[i] / width;
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if ((dx == 0 && dy == 0) || x + dx < 0 || x + dx >= width) continue;
          const auto it = position.find((y + dy) * width + x + dx);
          if (it == position.end() || run[it->second] >= 0) continue;
          run[it->second] = id;
          stack.push_back(it->second);
        }
      }
    }
    lengths.push_back(static_cast<int>(std::max(max_x - min_x, max_y - min_y)) + 1);
  }
  std::vector<int> out(cells.size());
  for (size_t i = 0; i < cells.size(); ++i) out[i] = lengths[run[i]];
  return out;
}

// The current map's tiles, numbered from its lowest, row by row.
struct TileLayout {
  double resolution = 0.1;
  double size = 5.0;
  Eigen::Vector2i first = Eigen::Vector2i::Zero();  // absolute tile of the lowest one
  int columns = 1;
  int rows = 1;

  int TileOf(int x, int y) const {
    const Eigen::Vector2i t = AbsoluteTileOf(x, y, resolution, size) - first;
    return std::clamp(t.y(), 0, rows - 1) * columns + std::clamp(t.x(), 0, columns - 1);
  }
};

// Submap a's wall cells against submap b, one bit per cell of a.walls; kept between checks until
// either submap is cast again (most pairs of a check after an optimisation are unchanged).
struct PairVerdicts {
  std::uint64_t generation_a = 0;
  std::uint64_t generation_b = 0;
  std::vector<std::uint64_t> confirmed;     // b has a wall within tolerance
  std::vector<std::uint64_t> contradicted;  // b saw it clearly free and has no wall near
};

PairVerdicts ComparePair(const SubmapView& a, const SubmapView& b) {
  PairVerdicts v;
  v.generation_a = a.generation;
  v.generation_b = b.generation;
  v.confirmed.assign((a.walls.size() + 63) / 64, 0);
  v.contradicted.assign(v.confirmed.size(), 0);
  for (size_t i = 0; i < a.walls.size(); ++i) {
    const std::uint8_t bits = b.At(a.walls[i].x(), a.walls[i].y());
    const std::uint64_t bit = std::uint64_t{1} << (i % 64);
    if (bits & kWallNear) {
      v.confirmed[i / 64] |= bit;
    } else if (bits & kFree) {
      v.contradicted[i / 64] |= bit;
    }
  }
  return v;
}

// A wall cell of submap `a` in the free space of submap `b`.
struct Contradiction {
  std::int64_t cell = 0;
  int a = 0;
  int b = 0;
  int tile = 0;
};

// The pairs of submaps `compared(a, b)` admits, compared cell by cell.
struct Comparison {
  std::vector<ConsistencyTile> tiles;         // confirmed, contradicted, one_sided, stray
  std::vector<std::int64_t> structure_cells;  // contradicted cells in structure, each once
  int disagreeing_pairs = 0;
};

using PairCache = std::vector<std::unordered_map<int, PairVerdicts>>;  // [a][b]

template <typename PairFn>
Comparison Compare(const std::vector<SubmapView>& views, PairCache& pairs, const CellFrame& frame,
                   const TileLayout& layout, const MapConsistencyOptions& options,
                   PairFn&& compared) {
  const int submaps = static_cast<int>(views.size());
  const int tile_count = layout.columns * layout.rows;
  Comparison out;
  out.tiles.resize(static_cast<size_t>(tile_count));
  std::vector<ConsistencyTile>& tiles = out.tiles;
  std::vector<Contradiction> contradictions;
  std::unordered_map<std::uint64_t, int> pair_counts;  // (a, b, tile) -> a's walls in b's free
  const auto pair_key = [&](int a, int b, int tile) {
    return (static_cast<std::uint64_t>(a) * submaps + b) * tile_count + tile;
  };
  std::vector<std::uint64_t> any_confirmed, any_contradicted;
  for (int a = 0; a < submaps; ++a) {
    const SubmapView& va = views[a];
    const size_t words = (va.walls.size() + 63) / 64;
    any_confirmed.assign(words, 0);
    any_contradicted.assign(words, 0);
    for (int b = 0; b < submaps; ++b) {
      if (!compared(a, b) || !va.Overlaps(views[b])) continue;
      PairVerdicts& verdicts = pairs[a][b];
      if (verdicts.generation_a != va.generation || verdicts.generation_b != views[b].generation) {
        verdicts = ComparePair(va, views[b]);
      }
      for (size_t w = 0; w < words; ++w) {
        any_confirmed[w] |= verdicts.confirmed[w];
        any_contradicted[w] |= verdicts.contradicted[w];
        for (std::uint64_t bits = verdicts.contradicted[w]; bits != 0; bits &= bits - 1) {
          const Eigen::Vector2i& cell = va.walls[w * 64 + __builtin_ctzll(bits)];
          const int tile = layout.TileOf(cell.x(), cell.y());
          contradictions.push_back({frame.Index(cell.x(), cell.y()), a, b, tile});
          ++pair_counts[pair_key(a, b, tile)];
        }
      }
    }
    for (size_t i = 0; i < va.walls.size(); ++i) {
      const std::uint64_t bit = std::uint64_t{1} << (i % 64);
      if ((any_confirmed[i / 64] & bit) && !(any_contradicted[i / 64] & bit)) {
        ++tiles[layout.TileOf(va.walls[i].x(), va.walls[i].y())].confirmed;
      }
    }
  }
  // Each (submap, cell) once below: its contradictions side by side.
  std::sort(contradictions.begin(), contradictions.end(),
            [](const Contradiction& l, const Contradiction& r) {
              return std::tie(l.a, l.cell, l.b) < std::tie(r.a, r.cell, r.b);
            });

  // Both ways in the same area: the pair's counts over the 3 x 3 tiles around.
  const auto count_around = [&](int a, int b, int tile) {
    const int row = tile / layout.columns, column = tile % layout.columns;
    int total = 0;
    for (int r = std::max(0, row - 1); r <= std::min(layout.rows - 1, row + 1); ++r) {
      for (int c = std::max(0, column - 1); c <= std::min(layout.columns - 1, column + 1); ++c) {
        const auto it = pair_counts.find(pair_key(a, b, r * layout.columns + c));
        if (it != pair_counts.end()) total += it->second;
      }
    }
    return total;
  };
  std::vector<std::pair<int, int>> mutual_pairs;
  // (submap, cell) wall cells, each once: contradicted both ways by some pair, or one way only.
  struct WallCell {
    std::int64_t cell = 0;
    int tile = 0;
    bool mutual = false;
  };
  std::vector<WallCell> wall_cells;
  for (size_t i = 0; i < contradictions.size();) {
    size_t j = i;
    WallCell w{contradictions[i].cell, contradictions[i].tile, false};
    for (; j < contradictions.size() && contradictions[j].a == contradictions[i].a &&
           contradictions[j].cell == contradictions[i].cell;
         ++j) {
      const Contradiction& c = contradictions[j];
      if (count_around(c.a, c.b, c.tile) >= options.min_mutual_cells &&
          count_around(c.b, c.a, c.tile) >= options.min_mutual_cells) {
        w.mutual = true;
        mutual_pairs.emplace_back(std::min(c.a, c.b), std::max(c.a, c.b));
      }
    }
    wall_cells.push_back(w);
    i = j;
  }
  std::sort(mutual_pairs.begin(), mutual_pairs.end());
  out.disagreeing_pairs = static_cast<int>(std::unique(mutual_pairs.begin(), mutual_pairs.end()) -
                                           mutual_pairs.begin());

  // Structure: the cells contradicted both ways count in runs of min_structure_length.
  const int min_length =
      std::max(1, static_cast<int>(std::lround(options.min_structure_length / frame.resolution)));
  std::vector<std::int64_t> mutual_cells;
  for (const WallCell& w : wall_cells) {
    if (w.mutual) mutual_cells.push_back(w.cell);
  }
  std::sort(mutual_cells.begin(), mutual_cells.end());
  mutual_cells.erase(std::unique(mutual_cells.begin(), mutual_cells.end()), mutual_cells.end());
  const std::vector<int> run_lengths = RunLengths(mutual_cells, frame.width);  // frame indices
  for (const WallCell& w : wall_cells) {
    ConsistencyTile& t = tiles[w.tile];
    if (!w.mutual) {
      ++t.one_sided;
      continue;
    }
    const size_t k =
        std::lower_bound(mutual_cells.begin(), mutual_cells.end(), w.cell) - mutual_cells.begin();
    ++(run_lengths[k] >= min_length ? t.contradicted : t.stray);
  }
  for (size_t k = 0; k < mutual_cells.size(); ++k) {
    if (run_lengths[k] >= min_length) out.structure_cells.push_back(mutual_cells[k]);
  }

  return out;
}

}  // namespace

absl::Status ValidateMapConsistencyOptions(const MapConsistencyOptions& o) {
  if (!(o.resolution > 0.0 && o.resolution <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("resolution must be in (0, 1] m: ", o.resolution));
  }
  if (o.submap_nodes < 1) return absl::InvalidArgumentError("submap_nodes must be at least 1");
  if (o.neighbour_submaps < 0) return absl::InvalidArgumentError("neighbour_submaps must be >= 0");
  if (!(o.tolerance >= 0.0 && o.tolerance <= 2.0)) {
    return absl::InvalidArgumentError(absl::StrCat("tolerance must be in [0, 2] m: ", o.tolerance));
  }
  if (o.min_hits < 1 || o.min_mutual_cells < 1 || o.tile_min_contradicted < 1 ||
      o.map_min_tiles < 1) {
    return absl::InvalidArgumentError(
        "min_hits, min_mutual_cells, tile_min_contradicted and map_min_tiles must be at least 1");
  }
  if (!(o.min_structure_length >= 0.0 && o.min_structure_length <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_structure_length must be in [0, 10] m: ", o.min_structure_length));
  }
  if (!(o.tile_size >= 10 * o.resolution && o.tile_size <= 1000.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("tile_size must be in [10 cells, 1000 m]: ", o.tile_size));
  }
  if (!(o.tile_limit > 0.0 && o.tile_limit <= 1.0) || !(o.map_limit > 0.0 && o.map_limit <= 1.0)) {
    return absl::InvalidArgumentError("tile_limit and map_limit must be in (0, 1]");
  }
  if (o.max_cells < 1000) return absl::InvalidArgumentError("max_cells must be at least 1000");
  return absl::OkStatus();
}

// The views of the last check: submap s was cast with its nodes at poses[s].
struct MapConsistencyChecker::Cache {
  double resolution = 0.0;
  std::vector<std::vector<Pose2>> poses;
  std::vector<SubmapView> views;
  PairCache pairs;
  std::uint64_t casts = 0;  // the last generation given to a view
};

MapConsistencyChecker::MapConsistencyChecker(const MapConsistencyOptions& options)
    : options_(options), cache_(std::make_unique<Cache>()) {}

MapConsistencyChecker::~MapConsistencyChecker() = default;

absl::StatusOr<MapConsistencyReport> CheckMapConsistency(const std::vector<NodeView>& nodes,
                                                         const MapConsistencyOptions& options) {
  MapConsistencyChecker checker(options);
  return checker.Check(nodes);
}

absl::StatusOr<MapConsistencyReport> MapConsistencyChecker::Check(
    const std::vector<NodeView>& nodes) {
  const MapConsistencyOptions& options = options_;
  if (absl::Status s = ValidateMapConsistencyOptions(options); !s.ok()) return s;
  MapConsistencyReport report;
  report.resolution = options.resolution;
  report.nodes = static_cast<int>(nodes.size());
  if (nodes.empty()) {
    report.verdict = "consistent: no nodes, nothing to check";
    return report;
  }
  const CellFrame frame = FrameOf(nodes, options);
  report.resolution = frame.resolution;
  const int submaps = (report.nodes + options.submap_nodes - 1) / options.submap_nodes;
  report.submaps = submaps;

  TileLayout layout;
  layout.resolution = frame.resolution;
  layout.size = options.tile_size;
  layout.first = AbsoluteTileOf(frame.lo.x(), frame.lo.y(), frame.resolution, options.tile_size);
  const Eigen::Vector2i last =
      AbsoluteTileOf(frame.lo.x() + frame.width - 1, frame.lo.y() + frame.height - 1,
                     frame.resolution, options.tile_size);
  layout.columns = last.x() - layout.first.x() + 1;
  layout.rows = last.y() - layout.first.y() + 1;
  const int tile_count = layout.columns * layout.rows;

  // Every submap alone, cast again only when its nodes changed (see the class comment).
  Cache& cache = *cache_;
  if (cache.resolution != frame.resolution) *cache_ = Cache{frame.resolution, {}, {}, {}, 0};
  cache.poses.resize(submaps);
  cache.views.resize(submaps);
  cache.pairs.resize(submaps);
  const int radius = static_cast<int>(std::ceil(options.tolerance / frame.resolution - 1e-9));
  const double move = frame.resolution / 4;
  const double turn = move / kReuseRange;
  for (int s = 0; s < submaps; ++s) {
    const int first = s * options.submap_nodes;
    const int end = std::min(report.nodes, first + options.submap_nodes);
    std::vector<Pose2>& cast_at = cache.poses[s];
    bool same = static_cast<int>(cast_at.size()) == end - first;
    for (int i = first; same && i < end; ++i) {
      const Pose2& now = nodes[i].global;
      const Pose2& then = cast_at[i - first];
      same = std::hypot(now.x - then.x, now.y - then.y) <= move &&
             std::abs(std::remainder(now.theta - then.theta, 2 * M_PI)) <= turn;
    }
    if (same) continue;
    cache.views[s] = ViewOf(nodes, first, end, frame, options, radius);
    cache.views[s].generation = ++cache.casts;
    cast_at.clear();
    for (int i = first; i < end; ++i) cast_at.push_back(nodes[i].global);
    ++report.submaps_cast;
  }
  const std::vector<SubmapView>& views = cache.views;
  std::vector<int> points(static_cast<size_t>(tile_count), 0);
  for (const SubmapView& view : views) {
    for (const auto& [tile, count] : view.points) {
      const Eigen::Vector2i t = tile - layout.first;
      points[std::clamp(t.y(), 0, layout.rows - 1) * layout.columns +
             std::clamp(t.x(), 0, layout.columns - 1)] += count;
    }
  }

  Comparison far = Compare(views, cache.pairs, frame, layout, options, [&](int a, int b) {
    return std::abs(a - b) > options.neighbour_submaps;
  });
  // The same measure between submaps next to each other in time, which the EKF's chain keeps
  // together whatever the loop closures did: what this map's data shows when it is consistent.
  const Comparison near = Compare(views, cache.pairs, frame, layout, options, [&](int a, int b) {
    return a != b && std::abs(a - b) <= options.neighbour_submaps;
  });
  report.disagreeing_pairs = far.disagreeing_pairs;
  for (std::int64_t cell : far.structure_cells) {
    const Eigen::Vector2i c = frame.CellAt(cell);
    report.contradicting_cells.push_back(frame.CentreOf(c.x(), c.y()));
  }
  {
    int contradicted = 0, evidence = 0;
    for (const ConsistencyTile& t : near.tiles) {
      contradicted += t.contradicted;
      evidence += t.confirmed + t.contradicted + t.one_sided + t.stray;
    }
    report.baseline_fraction = evidence > 0 ? double(contradicted) / evidence : 0.0;
  }
  for (int tile = 0; tile < tile_count; ++tile) {
    ConsistencyTile t = far.tiles[tile];
    t.points = points[tile];
    const int evidence = t.confirmed + t.contradicted + t.one_sided + t.stray;
    if (t.points == 0 && evidence == 0) continue;
    t.min = (layout.first + Eigen::Vector2i(tile % layout.columns, tile / layout.columns))
                .cast<double>() *
            options.tile_size;
    t.size = options.tile_size;
    t.fraction = evidence > 0 ? double(t.contradicted) / evidence : 0.0;
    if (t.contradicted >= options.tile_min_contradicted) {
      report.worst_tile_fraction = std::max(report.worst_tile_fraction, t.fraction);
      t.contradicts = t.fraction >= options.tile_limit;
    }
    report.confirmed += t.confirmed;
    report.contradicted += t.contradicted;
    report.one_sided += t.one_sided;
    report.stray += t.stray;
    report.tiles_contradicting += t.contradicts ? 1 : 0;
    report.tiles.push_back(t);
  }
  const int evidence = report.confirmed + report.contradicted + report.one_sided + report.stray;
  report.fraction = evidence > 0 ? double(report.contradicted) / evidence : 0.0;
  report.consistent =
      report.fraction < options.map_limit && report.tiles_contradicting < options.map_min_tiles;
  report.verdict = absl::StrFormat(
      "%s: %.1f%% of %d wall cells contradicted both ways (limit %.1f%%); %d areas of %.0f m "
      "contradict themselves (limit %d; an area: %.0f%% and %d cells; worst %.1f%%)",
      report.consistent ? "consistent" : "contradicts itself", 100.0 * report.fraction, evidence,
      100.0 * options.map_limit, report.tiles_contradicting, options.tile_size,
      options.map_min_tiles, 100.0 * options.tile_limit, options.tile_min_contradicted,
      100.0 * report.worst_tile_fraction);
  return report;
}

}  // namespace waymark::laser_slam

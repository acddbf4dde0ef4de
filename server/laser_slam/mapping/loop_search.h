#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LOOP_SEARCH_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LOOP_SEARCH_H_

// One loop search's matching (docs/laser-slam.md, "Loop closure"): a node's query points against
// one candidate submap, in a window or over the whole submap (a global search, first on the
// coarse grid), the refinement on the fine grid, and the rival tests that refuse or loosen a
// closure. And the submaps' search grids, built on demand and kept within a memory budget. The
// back end (mapping_backend.h) chooses the candidates and keeps the graph; nothing here sees it.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <unordered_map>

#include <Eigen/Core>

#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/mapping_options.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/seen_mask.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// The query's points at the resolutions the searches use (all in the node's frame).
struct LoopQuery {
  PointCloud points;  // one per point_cell: refinement and final score
  PointCloud sparse;  // one per 2 point_cell: the windowed search (and its rival tests)
  PointCloud coarse;  // one per 2 coarse_search_factor point_cell: the global search's
  PointCloud coarser;  // one per 4 coarse_search_factor point_cell: a global search on what
                       // the submap looked at (MappingOptions::global_min_overlap)
};
LoopQuery MakeLoopQuery(const PointCloud& points, const MappingOptions& options);

// A submap's search grids, in its first node's frame. `fine` is the search grid; `coarse` the
// coarse_search_factor one of global searches (called only then); `fine_frame` the lattice of
// the fine grid (what a global search covers), known without building it.
struct SubmapGrids {
  std::function<std::shared_ptr<const SearchPyramid>()> fine;
  std::function<std::shared_ptr<const SearchPyramid>()> coarse;
  std::function<GridFrame()> fine_frame;
  // Where the submap's scans looked (a global search below min_score over the whole query asks;
  // nullptr or an empty mask: the whole query only).
  std::function<std::shared_ptr<const SeenMask>()> seen;
};

struct LoopMatch {
  enum class Verdict { kRejected, kAmbiguous, kAccepted };
  Verdict verdict = Verdict::kRejected;
  bool loosened = false;   // accepted, trusted only to a near rival's offset
  Pose2 pose;              // of the node in the submap's frame
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();
  double score = 0.0;    // over the whole query
  bool where_seen = false;  // accepted on the points where the submap looked (global_min_overlap)
};

// Matches the query against one submap: in `window` around `initial` (the node as the graph has
// it), or with `global` the whole submap at every heading (which may accept a match on the points
// where the submap looked: MappingOptions::global_min_overlap).
LoopMatch MatchSubmap(const LoopQuery& query, const SubmapGrids& grids, const Pose2& initial,
                      const SearchWindow& window, bool global, const MappingOptions& options);

// Submap pyramids by (submap, coarsening), least recently used dropped beyond `budget_bytes`;
// the fine grids' frames are kept for good (a few bytes each). Not thread-safe.
class PyramidCache {
 public:
  explicit PyramidCache(size_t budget_bytes) : budget_(budget_bytes) {}
  std::shared_ptr<const SearchPyramid> Find(int submap, int coarsening);
  void Insert(int submap, int coarsening, std::shared_ptr<const SearchPyramid> pyramid);
  std::optional<GridFrame> Frame(int submap) const;
  void SetFrame(int submap, const GridFrame& frame) { frames_[submap] = frame; }
  // Forgets the submap's pyramids and frame (it was pruned).
  void Erase(int submap);
  size_t bytes() const { return bytes_; }

 private:
  struct Entry {
    std::int64_t key = 0;
    std::shared_ptr<const SearchPyramid> pyramid;
    size_t bytes = 0;
  };
  static std::int64_t Key(int submap, int coarsening) {
    return static_cast<std::int64_t>(submap) * 64 + coarsening;
  }
  size_t budget_;
  size_t bytes_ = 0;
  std::list<Entry> entries_;  // most recently used last
  std::unordered_map<std::int64_t, std::list<Entry>::iterator> index_;
  std::unordered_map<int, GridFrame> frames_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LOOP_SEARCH_H_

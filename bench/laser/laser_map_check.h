#ifndef WAYMARK_BENCH_LASER_LASER_MAP_CHECK_H_
#define WAYMARK_BENCH_LASER_LASER_MAP_CHECK_H_

// waymark-laser-eval's report of the map: the back end's loop closures, and the map self-check
// (server/laser_slam/mapping/map_consistency.h) run on the final graph, its report in
// summary.json and drawn where people look at the map: the contradicting cells in red on map.png
// (the segment map) and on occupancy.png (the occupancy grid at the optimised poses, the picture
// that shows a folded corridor).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/datasets/carmen_log.h"
#include "client/render/map_render.h"
#include "server/laser_slam/mapping/map_consistency.h"
#include "server/laser_slam/mapping/mapping_backend.h"

namespace waymark::bench {

// A CARMEN laser line as the engine's scan (stamp, beam geometry, ranges).
laser_slam::LaserScan ToLaserScan(const adapters::CarmenLaser& laser);

// summary.json's "mapping": the loop-closing back end's counters and times, and the loop
// closures that disagree with the final graph.
nlohmann::json MappingJson(const laser_slam::MappingBackend& backend);

struct MapCheck {
  laser_slam::MapConsistencyOptions options;
  laser_slam::MapConsistencyReport report;
  double check_ms = 0.0;  // CheckMapConsistency alone, steady clock
};

// A map's nodes (scan, stamp, global pose, points) and its submap size as a file: the check's
// input, independent of the back end's checkpoint format, so that maps made by different builds
// can be checked again by one waymark-map-check. PermissionDenied / NotFound / DataLoss.
struct SavedNodes {
  std::vector<laser_slam::NodeView> nodes;
  int submap_nodes = 25;
};
absl::Status WriteNodesFile(const std::filesystem::path& path,
                            const std::vector<laser_slam::NodeView>& nodes, int submap_nodes);
absl::StatusOr<SavedNodes> ReadNodesFile(const std::filesystem::path& path);

// The graph's loop constraints as text, one line each: the stamps of their from and to nodes,
// the relative pose (x y theta), its sigmas, enabled (0/1) and score. To check the closures
// against a reference (relations or known poses) offline. PermissionDenied.
absl::Status WriteClosuresFile(const std::filesystem::path& path,
                               const std::vector<laser_slam::NodeView>& nodes,
                               const std::vector<laser_slam::GraphConstraint>& constraints);

// The check on the backend's nodes, grouped as `submap_nodes` (MappingOptions::submap_nodes).
absl::StatusOr<MapCheck> RunMapCheck(const std::vector<laser_slam::NodeView>& nodes,
                                     int submap_nodes);

// The self-check run after every optimisation of a replay (waymark-laser-eval
// --check-after-optimisations): what running it there would cost the back end. Incremental: one
// MapConsistencyChecker that keeps submap views between checks; otherwise a fresh check each time.
class OptimisationChecks {
 public:
  OptimisationChecks(int submap_nodes, bool incremental);
  // Checks when the back end optimised since the last call (its revision changed).
  absl::Status AfterScan(const laser_slam::MappingBackend& backend);
  // Checks, per-check ms (p50 / p99 / max / total, Nodes() copy included), submaps cast.
  nlohmann::json Json() const;

 private:
  laser_slam::MapConsistencyOptions options_;
  bool incremental_ = true;
  std::unique_ptr<laser_slam::MapConsistencyChecker> checker_;
  std::uint64_t revision_ = 0;
  std::vector<double> ms_;
  std::int64_t submaps_cast_ = 0;
  std::int64_t submaps_seen_ = 0;
  int failing_ = 0;  // checks whose verdict was "contradicts itself"
};

// summary.json's "self_check": verdict, fractions, counts, limits, time, and the tiles with
// evidence (their cells are not listed: occupancy.png shows them).
nlohmann::json MapCheckJson(const MapCheck& check);

// The contradicting cells as red marks for a map scene (one short polyline per cell, the first
// labelled for the legend).
std::vector<cli::ScenePolyline> ContradictionPolylines(const MapCheck& check);

// A rectangle of the map frame (m) to cut out of a picture and enlarge (looking at one area).
struct PictureView {
  cli::Vec2 min;
  cli::Vec2 max;
};

// DIR/occupancy.png: the occupancy grid of `nodes` at `resolution`, the trajectory in green,
// contradicting cells in red, the outlines of areas that contradict themselves in orange; only
// `view`, enlarged to at least 800 pixels a side, when given.
absl::Status WriteCheckedOccupancyPicture(const std::filesystem::path& path,
                                          const std::vector<laser_slam::NodeView>& nodes,
                                          const MapCheck& check,
                                          const std::vector<cli::Vec2>& trajectory,
                                          double resolution = 0.05,
                                          const std::optional<PictureView>& view = std::nullopt);

// A small picture of the same map for a page of many maps (docs/results.md, "Every map, looked
// at"): the occupancy grid rendered at the resolution that makes its longer side `size_px` cells,
// one pixel a cell (no trajectory: the walls are what is judged), the self-check's contradicting cells in red, the
// areas that contradict themselves outlined in orange, the verdict's first words top left; an
// 8-bit palette PNG (client/render's WriteSmallPalettePicture), tens of KB.
absl::Status WriteSmallCheckedPicture(const std::filesystem::path& path,
                                      const std::vector<laser_slam::NodeView>& nodes,
                                      const MapCheck& check, int size_px = 360);

}  // namespace waymark::bench

#endif  // WAYMARK_BENCH_LASER_LASER_MAP_CHECK_H_

// MapRegistry's reads of a map's contents (issue 38): its grid, its segment map and its node
// origins, each placing the tied-in trajectories by the map's pose graph (kept between reads,
// map_graph_cache.h) or one at a time. The rest of the registry: map_registry.cc.

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/map_graph_cache.h"
#include "server/laser_slam/mapping/map_segments.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/service/slam/map_follow_codec.h"
#include "server/service/slam/map_registry.h"
#include "server/service/slam/slam_params.h"

namespace waymark::service {

namespace {

bool IsOrigin(const v1::Pose2D& pose) {
  return pose.x() == 0 && pose.y() == 0 && pose.theta() == 0;
}

// A map, its tied-in trajectories (indices into map.trajectories()) and how many are not tied
// in: what the map's grid and segments are drawn from.
struct TiedMap {
  v1::Map map;
  std::vector<int> tied;
  uint32_t untied = 0;
};

// FAILED_PRECONDITION when no trajectory is tied in (or the map's own error).
// The indices of the map's tied-in trajectories.
std::vector<int> TiedIndices(const v1::Map& map) {
  std::vector<int> tied;
  for (int i = 0; i < map.trajectories_size(); ++i) {
    if (map.trajectories(i).tied_in()) tied.push_back(i);
  }
  return tied;
}

absl::StatusOr<TiedMap> SplitTied(const std::string& name, absl::StatusOr<v1::Map> map) {
  if (!map.ok()) return map.status();
  TiedMap split;
  split.map = *std::move(map);
  split.tied = TiedIndices(split.map);
  split.untied = static_cast<uint32_t>(split.map.trajectories_size() - split.tied.size());
  if (!split.tied.empty()) return split;
  return absl::FailedPreconditionError(absl::StrCat(
      "map \"", name, "\" has no trajectory yet: no session has joined it (CreateSession with "
      "map, `waymark slam replay LOG --map ", name, "`)"));
}

// The head every answer about a map's contents shares: its name, revision and untied count.
template <class Answer>
void SetMapHead(const std::string& name, const TiedMap& split, Answer* answer) {
  answer->set_map(name);
  answer->set_revision(split.map.revision());
  answer->set_untied_trajectories(split.untied);
}

// A session's error while reading one of the map's trajectories, naming the map and the session.
absl::Status TrajectoryError(const std::string& name, const v1::MapTrajectory& trajectory,
                             const absl::Status& status) {
  return absl::Status(status.code(), absl::StrCat("map \"", name, "\": trajectory of session ",
                                                  trajectory.session_id(), ": ", status.message()));
}

// A trajectory's nodes and where it lies in the map (its origin and origin samples).
absl::StatusOr<laser_slam::TiedTrajectory> InMap(const std::string& name,
                                                 const v1::MapTrajectory& trajectory,
                                                 const MapRegistry::SessionNodes& session_nodes) {
  absl::StatusOr<TrajectoryNodes> own = session_nodes(trajectory.session_id());
  if (!own.ok()) return TrajectoryError(name, trajectory, own.status());
  return laser_slam::TiedTrajectory{FromProtoPose(trajectory.origin()), std::move(own->nodes),
                                    SamplesOf(trajectory), std::move(own->loops)};
}

// The map's tied-in trajectories (`tied`, indices into map.trajectories()) and where each node
// of each lies: one graph over all of them, or each on its own (CurrentOrigins).
struct PlacedMap {
  std::vector<laser_slam::TiedTrajectory> trajectories;
  std::vector<std::vector<laser_slam::OriginSample>> origins;
};
// `graph`: the map's pose graph, solved or its kept solution; null: one trajectory at a time.
absl::StatusOr<PlacedMap> Place(const std::string& name, const v1::Map& map,
                                const std::vector<int>& tied,
                                const MapRegistry::SessionNodes& session_nodes,
                                laser_slam::MapGraphCache* graph) {
  PlacedMap placed;
  for (int i : tied) {
    absl::StatusOr<laser_slam::TiedTrajectory> in_map =
        InMap(name, map.trajectories(i), session_nodes);
    if (!in_map.ok()) return in_map.status();
    placed.trajectories.push_back(*std::move(in_map));
  }
  if (graph != nullptr) {
    placed.origins = graph->Solve(placed.trajectories);
  } else {
    for (const laser_slam::TiedTrajectory& t : placed.trajectories) {
      placed.origins.push_back(laser_slam::CurrentOrigins(t));
    }
  }
  return placed;
}

}  // namespace

std::shared_ptr<laser_slam::MapGraphCache> MapRegistry::Graph(const std::string& name) {
  if (!map_graph_) return nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  std::shared_ptr<laser_slam::MapGraphCache>& graph = graphs_[name];
  if (graph == nullptr) graph = std::make_shared<laser_slam::MapGraphCache>();
  return graph;
}

std::optional<laser_slam::MapGraphCache::Stats> MapRegistry::GraphStats(
    const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = graphs_.find(name);
  if (it == graphs_.end()) return std::nullopt;
  return it->second->stats();
}

absl::StatusOr<v1::Map> MapRegistry::GetMapWithNodeOrigins(const std::string& name,
                                                            const SessionNodes& session_nodes) {
  absl::StatusOr<v1::Map> map = GetMap(name);
  if (!map.ok()) return map;
  if (map_graph_) {
    const std::vector<int> tied = TiedIndices(*map);
    absl::StatusOr<PlacedMap> placed = Place(name, *map, tied, session_nodes, Graph(name).get());
    if (placed.ok() && tied.size() > 1) {
      for (size_t t = 0; t < tied.size(); ++t) {
        v1::MapTrajectory* trajectory = map->mutable_trajectories(tied[t]);
        for (const laser_slam::OriginSample& sample : placed->origins[t]) {
          SetSample(sample, trajectory->add_node_origins());
        }
      }
      return map;
    }
    // A session not readable here: each trajectory as it can be placed on its own.
  }
  for (v1::MapTrajectory& trajectory : *map->mutable_trajectories()) {
    if (!trajectory.tied_in() || trajectory.origin_samples().empty()) continue;
    absl::StatusOr<laser_slam::TiedTrajectory> in_map = InMap(name, trajectory, session_nodes);
    if (!in_map.ok()) continue;  // a session not readable here: its samples, interpolated
    for (const laser_slam::OriginSample& sample : laser_slam::CurrentOrigins(*in_map)) {
      SetSample(sample, trajectory.add_node_origins());
    }
  }
  return map;
}

absl::StatusOr<v1::MapSegmentMap> MapRegistry::GetMapSegments(
    const std::string& name, const SessionSegments& session_segments,
    const SessionNodes& session_nodes) {
  absl::StatusOr<TiedMap> split = SplitTied(name, GetMap(name));
  if (!split.ok()) return split.status();
  v1::MapSegmentMap response;
  SetMapHead(name, *split, &response);
  absl::StatusOr<PlacedMap> where =
      Place(name, split->map, split->tied, session_nodes, Graph(name).get());
  if (!where.ok()) return where.status();
  std::vector<laser_slam::PlacedSegment> placed;
  for (size_t t = 0; t < split->tied.size(); ++t) {
    const v1::MapTrajectory& trajectory = split->map.trajectories(split->tied[t]);
    response.add_session_ids(trajectory.session_id());
    absl::StatusOr<v1::SegmentMap> own = session_segments(trajectory.session_id());
    if (!own.ok()) return TrajectoryError(name, trajectory, own.status());
    std::vector<laser_slam::MapSegment> segments;
    segments.reserve(own->segments_size());
    for (const v1::MapSegment& s : own->segments()) segments.push_back(FromProtoSegment(s));
    for (laser_slam::MapSegment& s : laser_slam::SegmentsInMapFrame(
             where->trajectories[t], segments, where->origins[t])) {
      placed.push_back({std::move(s), static_cast<int>(t)});
    }
  }
  const laser_slam::MergedSegments merged = laser_slam::MergeTrajectorySegments(std::move(placed));
  for (const laser_slam::MapSegment& s : merged.segments) {
    *response.add_segments() = ToProtoSegment(s);
  }
  response.set_fused_segments(static_cast<uint32_t>(merged.fused));
  return response;
}

absl::StatusOr<v1::MapOccupancyGrid> MapRegistry::GetMapGrid(const std::string& name,
                                                              std::optional<double> resolution,
                                                              const SessionGrid& session_grid,
                                                              const SessionNodes& session_nodes) {
  absl::StatusOr<TiedMap> split = SplitTied(name, GetMap(name));
  if (!split.ok()) return split.status();
  v1::MapOccupancyGrid response;
  SetMapHead(name, *split, &response);
  std::vector<const v1::MapTrajectory*> tied;
  for (int i : split->tied) tied.push_back(&split->map.trajectories(i));
  for (const v1::MapTrajectory* trajectory : tied) {
    response.add_session_ids(trajectory->session_id());
  }
  if (tied.size() == 1 && IsOrigin(tied.front()->origin())) {
    // The map is that session's: its grid cell for cell.
    absl::StatusOr<v1::OccupancyGrid> grid = session_grid(tied.front()->session_id());
    if (!grid.ok()) return grid.status();
    *response.mutable_grid() = *std::move(grid);
    return response;
  }
  const double cell = resolution.value_or(0.05);
  if (absl::Status s = InRange(cell, "resolution", 0.01, 1.0, false, "m"); !s.ok()) return s;
  absl::StatusOr<PlacedMap> where =
      Place(name, split->map, split->tied, session_nodes, Graph(name).get());
  if (!where.ok()) return where.status();
  std::vector<laser_slam::NodeView> nodes;
  for (size_t t = 0; t < where->trajectories.size(); ++t) {
    for (laser_slam::NodeView& node :
         laser_slam::NodesPlacedBy(where->trajectories[t], where->origins[t])) {
      nodes.push_back(std::move(node));
    }
  }
  // As a session's grid (LaserSessionEngine::FillOccupancyGrid): one answer within gRPC's
  // message limit, a coarser resolution when the map needs it.
  constexpr std::int64_t kMaxGridCells = 16'000'000;
  absl::StatusOr<laser_slam::OccupancyGrid> grid = laser_slam::RenderOccupancy(
      nodes, laser_slam::ResolutionThatFits(nodes, cell, kMaxGridCells), kMaxGridCells);
  if (!grid.ok()) {
    return absl::Status(grid.status().code(),
                        absl::StrCat("map \"", name, "\": ", grid.status().message()));
  }
  *response.mutable_grid() = ToProtoGrid(*grid);
  response.mutable_grid()->set_map_revision(split->map.revision());
  response.mutable_grid()->set_scans(static_cast<uint32_t>(nodes.size()));
  return response;
}

}  // namespace waymark::service

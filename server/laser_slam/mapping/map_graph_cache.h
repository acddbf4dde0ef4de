#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_CACHE_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_CACHE_H_

// The last solution of one shared map's pose graph (map_graph.h), kept between reads (issue 38).
// The map's grid, its segment map and its node origins each place the trajectories by the graph,
// and clients read them over and over while nothing changed (a live view polls them): solving
// again costs 50-160 ms for three robots on ACES or Intel. A solution is reused only when every
// input the solver reads is what it was solved from, compared in full (not hashed): the
// trajectories' origins, their nodes' scans, stamps, poses and step sigmas, their follow samples
// and their loop closures. A node's points are not read by the solver and not compared.
//
// Why not checkpointed: the solution is a function of what is stored already (the sessions'
// checkpointed nodes and closures, the map's samples), so a server that restarts solves it once
// on the first read and holds it from then on; a stored copy could only go stale.
//
// Thread-safe. Two reads of a changed map may both solve; the later solution is kept.

#include <cstdint>
#include <mutex>
#include <vector>

#include "server/laser_slam/mapping/map_graph.h"

namespace waymark::laser_slam {

class MapGraphCache {
 public:
  explicit MapGraphCache(const MapGraphOptions& options = {}) : options_(options) {}

  // SolveMapGraph(trajectories, options), or the kept solution when the inputs are unchanged.
  std::vector<std::vector<OriginSample>> Solve(const std::vector<TiedTrajectory>& trajectories);

  struct Stats {
    std::uint64_t solved = 0;  // reads that ran the solver
    std::uint64_t reused = 0;  // reads answered from the kept solution
  };
  Stats stats() const;

 private:
  MapGraphOptions options_;
  mutable std::mutex mutex_;
  bool kept_ = false;
  std::vector<double> inputs_;  // what the kept solution was solved from, flattened
  std::vector<std::vector<OriginSample>> solution_;
  Stats stats_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_MAP_GRAPH_CACHE_H_

// waymark-laser-revisit (issue 38, "Memory and time over a long revisit run"): the back end of a
// robot driving the same 30 m loop through the tests' pillar hall lap after lap (true scans,
// odometry 1 % long and turning 0.002 rad per 0.25 m to the left), with pruning on and off
// (MappingOptions::prune_redundant_submaps; --no-pruning: off). One line per lap: nodes, nodes in
// the graph, constraints, the optimisations' median time in that lap and the process's resident
// memory. Run the two settings as two processes to compare their memory.
//
//   waymark-laser-revisit [--laps N] [--no-pruning] [--json]

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench/common/bench_timing.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace ls = waymark::laser_slam;

namespace {

void Drive(bool prune, int laps, bool json) {
  ls::MappingOptions options;
  options.prune_redundant_submaps = prune;
  ls::MappingBackend backend(options);
  const std::vector<ls::testing::Wall> walls = ls::testing::PillarOffice();
  const std::vector<ls::Pose2> lap = ls::testing::PillarOfficeLap();
  ls::Pose2 own, previous = lap.front();
  std::uint64_t scan = 0;
  size_t optimisations = 0;
  for (int l = 1; l <= laps; ++l) {
    for (const ls::Pose2& truth : lap) {
      if (scan > 0) own = ls::testing::DriftingStep(own, previous, truth);
      previous = truth;
      ++scan;
      backend.AddScan(scan, static_cast<double>(scan), own, ls::testing::ScanPoints(walls, truth));
    }
    backend.Flush();
    const ls::MappingStats stats = backend.Stats();
    const std::vector<double> lap_ms(stats.optimize_ms.begin() + optimisations, stats.optimize_ms.end());
    optimisations = stats.optimize_ms.size();
    const size_t constraints = backend.Constraints().size();
    const double optimize_ms = waymark::bench::Percentile(lap_ms, 0.5);
    const double rss_mb = waymark::bench::ResidentMb();
    if (json) {
      std::printf("{\"pruning\": %s, \"lap\": %d, \"nodes\": %d, \"graph_nodes\": %d, "
                  "\"constraints\": %zu, \"optimize_ms_p50\": %.2f, \"rss_mb\": %.1f}\n",
                  prune ? "true" : "false", l, stats.nodes, stats.graph_nodes, constraints,
                  optimize_ms, rss_mb);
    } else {
      std::printf("| %s | %d | %d | %d | %zu | %.2f | %.1f |\n", prune ? "on" : "off", l,
                  stats.nodes, stats.graph_nodes, constraints, optimize_ms, rss_mb);
    }
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int laps = 10;
  bool json = false, prune = true;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--laps") == 0 && i + 1 < argc) {
      laps = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--json") == 0) {
      json = true;
    } else if (std::strcmp(argv[i], "--no-pruning") == 0) {
      prune = false;
    } else {
      std::fprintf(stderr, "usage: waymark-laser-revisit [--laps N] [--no-pruning] [--json]\n");
      return 2;
    }
  }
  if (!json) {
    std::printf("| pruning | lap | nodes | in the graph | constraints | optimisation p50 (ms) | RSS (MB) |\n");
    std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  }
  Drive(prune, laps, json);
  return 0;
}

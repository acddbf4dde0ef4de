// waymark-laser-revisit (issue 38, "Memory and time over a long revisit run"): a robot driving
// the same 30 m loop through the tests' pillar hall lap after lap (true scans, odometry 1 % long
// and turning 0.002 rad per 0.25 m to the left), with pruning on and off
// (MappingOptions::prune_redundant_submaps; --no-pruning: off). One line per lap: nodes, nodes in
// the graph, constraints, the optimisations' median time in that lap and the process's resident
// memory. Run the two settings as two processes to compare their memory.
//
// By default the back end alone is driven (its nodes' points given). --engine drives a whole
// session instead (LaserSlam: the segment EKF, its map and the trajectory beside the back end),
// from simulated LMS200 scans and odometry, and adds the segments in its map, the poses of its
// trajectory and the heap in use (mallinfo2) to each line: what a server's session holds.
//
//   waymark-laser-revisit [--laps N] [--no-pruning] [--engine] [--json]

#include <malloc.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench/common/bench_timing.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace ls = waymark::laser_slam;

namespace {

// What one lap left behind.
struct Lap {
  ls::MappingStats stats;
  std::size_t constraints = 0;
  double optimize_ms = 0.0;
  long segments = -1;     // the session's map (--engine)
  long trajectory = -1;   // its poses (--engine)
  double heap_mb = -1.0;  // (--engine)
};

void Print(bool prune, int lap, const Lap& l, bool json) {
  const double rss_mb = waymark::bench::ResidentMb();
  if (json) {
    std::printf("{\"pruning\": %s, \"lap\": %d, \"nodes\": %d, \"graph_nodes\": %d, "
                "\"constraints\": %zu, \"optimize_ms_p50\": %.2f, \"rss_mb\": %.1f",
                prune ? "true" : "false", lap, l.stats.nodes, l.stats.graph_nodes, l.constraints,
                l.optimize_ms, rss_mb);
    if (l.segments >= 0) {
      std::printf(", \"segments\": %ld, \"trajectory\": %ld, \"heap_mb\": %.2f", l.segments,
                  l.trajectory, l.heap_mb);
    }
    std::printf("}\n");
  } else {
    std::printf("| %s | %d | %d | %d | %zu | %.2f | %.1f |", prune ? "on" : "off", lap,
                l.stats.nodes, l.stats.graph_nodes, l.constraints, l.optimize_ms, rss_mb);
    if (l.segments >= 0) std::printf(" %ld | %ld | %.2f |", l.segments, l.trajectory, l.heap_mb);
    std::printf("\n");
  }
  std::fflush(stdout);
}

// The optimisations' median time since the last lap.
double LapOptimizeMs(const ls::MappingStats& stats, std::size_t* optimisations) {
  const std::vector<double> lap_ms(stats.optimize_ms.begin() + *optimisations,
                                   stats.optimize_ms.end());
  *optimisations = stats.optimize_ms.size();
  return waymark::bench::Percentile(lap_ms, 0.5);
}

// A whole session (LaserSlam, back end inline): simulated scans at 10 Hz, a pose every 0.25 m.
void DriveEngine(bool prune, int laps, bool json) {
  ls::SlamOptions options;
  options.mapping.prune_redundant_submaps = prune;
  ls::LaserSlam slam(options);
  const std::vector<ls::testing::Wall> walls = ls::testing::PillarOffice();
  const std::vector<ls::Pose2> lap = ls::testing::PillarOfficeLap();
  const ls::ScanGeometry geometry = ls::testing::Lms200Geometry();
  ls::Pose2 own, previous = lap.front();
  double stamp = 0.0;
  std::size_t optimisations = 0;
  bool first = true;
  for (int l = 1; l <= laps; ++l) {
    for (const ls::Pose2& truth : lap) {
      if (!first) own = ls::testing::DriftingStep(own, previous, truth);
      first = false;
      previous = truth;
      stamp += 0.1;
      if (!slam.AddOdometry({stamp, own}).ok()) std::abort();
      ls::LaserScan scan =
          ls::testing::CastScan(walls, truth, geometry, ls::testing::RayCastOptions{}, nullptr);
      scan.stamp = stamp;
      if (!slam.AddScan(scan).ok()) std::abort();
    }
    slam.FlushBackend();
    Lap out;
    out.stats = slam.backend()->Stats();
    out.constraints = slam.backend()->Constraints().size();
    out.optimize_ms = LapOptimizeMs(out.stats, &optimisations);
    out.segments = static_cast<long>(slam.Map().size());
    out.trajectory = static_cast<long>(slam.LocalTrajectory().size());
    out.heap_mb = static_cast<double>(mallinfo2().uordblks) / (1024.0 * 1024.0);
    Print(prune, l, out, json);
  }
}

void Drive(bool prune, int laps, bool json) {
  ls::MappingOptions options;
  options.prune_redundant_submaps = prune;
  ls::MappingBackend backend(options);
  const std::vector<ls::testing::Wall> walls = ls::testing::PillarOffice();
  const std::vector<ls::Pose2> lap = ls::testing::PillarOfficeLap();
  ls::Pose2 own, previous = lap.front();
  std::uint64_t scan = 0;
  std::size_t optimisations = 0;
  for (int l = 1; l <= laps; ++l) {
    for (const ls::Pose2& truth : lap) {
      if (scan > 0) own = ls::testing::DriftingStep(own, previous, truth);
      previous = truth;
      ++scan;
      backend.AddScan(scan, static_cast<double>(scan), own, ls::testing::ScanPoints(walls, truth));
    }
    backend.Flush();
    Lap out;
    out.stats = backend.Stats();
    out.constraints = backend.Constraints().size();
    out.optimize_ms = LapOptimizeMs(out.stats, &optimisations);
    Print(prune, l, out, json);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int laps = 10;
  bool json = false, prune = true, engine = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--laps") == 0 && i + 1 < argc) {
      laps = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--json") == 0) {
      json = true;
    } else if (std::strcmp(argv[i], "--no-pruning") == 0) {
      prune = false;
    } else if (std::strcmp(argv[i], "--engine") == 0) {
      engine = true;
    } else {
      std::fprintf(stderr,
                   "usage: waymark-laser-revisit [--laps N] [--no-pruning] [--engine] [--json]\n");
      return 2;
    }
  }
  if (!json) {
    std::printf("| pruning | lap | nodes | in the graph | constraints | optimisation p50 (ms) | "
                "RSS (MB) |%s\n",
                engine ? " segments | trajectory poses | heap (MB) |" : "");
    std::printf("|---|---:|---:|---:|---:|---:|---:|%s\n", engine ? "---:|---:|---:|" : "");
  }
  if (engine) {
    DriveEngine(prune, laps, json);
  } else {
    Drive(prune, laps, json);
  }
  return 0;
}

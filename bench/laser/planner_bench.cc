// Active-exploration planner cost per decision (Google Benchmark): ExplorationPlanner::Decide
// (server/laser_slam/exploration/exploration_planner.h) against the number of candidate controls and of
// mapped segments, with wander mode as the baseline.
//
// The world is synthetic and deterministic: an office-like layout of walls within 15 m of the
// robot (axis-aligned walls on a 2.5 m grid of lines plus oblique ones, 0.5-4 m long, fixed seed),
// none within 1.2 m of the robot: every candidate's 0.6 m path plus the 0.4 m required clearance
// stays free, so all candidates are feasible and scored (the worst case for the prediction, and
// the feasible count does not vary with the world). The first N walls of one fixed list of 400
// make the world with N segments (the worlds are nested). The map is those walls as MapSegments,
// each endpoint real or virtual at random so that frontiers exist; the scan is a noise-free ray
// cast of the same walls from the robot at the origin (181 beams, 1 degree, as in
// tests/laser_slam/exploration_test.cc).
//
// Every iteration builds a fresh planner (cheap) and makes one decision, so no trap or wall-
// following state carries over between iterations. Counters: candidates (the planner's actual
// count), segments, feasible (collision-free candidates), frontiers and occluders (what the
// observation predictor selects within the 0.6 m a control travels).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "server/laser_slam/exploration/exploration_planner.h"
#include "server/laser_slam/exploration/observation_prediction.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::CastScan;
using testing::Lms200OneDegreeGeometry;
using testing::RayCastOptions;
using testing::SegmentBetween;
using testing::Wall;

constexpr int kMaxWalls = 400;
constexpr double kExtent = 15.0;       // walls within [-15, 15] m in x and y
constexpr double kRobotFree = 1.2;     // no wall nearer the robot than this (m)
constexpr std::uint32_t kSeed = 20240611;

double DistanceToOrigin(const Wall& w) {
  const Eigen::Vector2d ab = w.b - w.a;
  const double t = std::clamp(-w.a.dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (w.a + t * ab).norm();
}

struct World {
  std::vector<Wall> walls;
  std::vector<EndpointType> left;  // endpoint types of the mapped segment of each wall
  std::vector<EndpointType> right;
};

// kMaxWalls walls, 70% axis-aligned on a 2.5 m grid of lines (offices), 30% oblique.
const World& FullWorld() {
  static const World world = [] {
    World w;
    std::mt19937 rng(kSeed);
    std::uniform_real_distribution<double> coord(-kExtent, kExtent);
    std::uniform_real_distribution<double> length(0.5, 4.0);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_int_distribution<int> grid_line(-6, 6);  // x or y = 2.5 k
    while (static_cast<int>(w.walls.size()) < kMaxWalls) {
      const double len = length(rng);
      Eigen::Vector2d centre(coord(rng), coord(rng));
      double angle;
      if (unit(rng) < 0.7) {
        if (unit(rng) < 0.5) {
          centre.y() = 2.5 * grid_line(rng);
          angle = 0.0;
        } else {
          centre.x() = 2.5 * grid_line(rng);
          angle = M_PI / 2;
        }
      } else {
        angle = M_PI * unit(rng);
      }
      const Eigen::Vector2d half = 0.5 * len * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const Wall wall{centre - half, centre + half};
      if (std::abs(wall.a.x()) > kExtent || std::abs(wall.a.y()) > kExtent ||
          std::abs(wall.b.x()) > kExtent || std::abs(wall.b.y()) > kExtent ||
          DistanceToOrigin(wall) < kRobotFree) {
        continue;
      }
      w.walls.push_back(wall);
      w.left.push_back(unit(rng) < 0.5 ? EndpointType::kReal : EndpointType::kVirtual);
      w.right.push_back(unit(rng) < 0.5 ? EndpointType::kReal : EndpointType::kVirtual);
    }
    return w;
  }();
  return world;
}

MapSegment ToSegment(std::uint64_t id, const Wall& w, EndpointType left, EndpointType right) {
  MapSegment s = SegmentBetween(id, w.a.x(), w.a.y(), w.b.x(), w.b.y(), left, right);
  s.line_covariance = Eigen::Matrix2d::Identity() * 1e-4;
  s.observations = 3;
  return s;
}

// The view of the world made of the first `segments` walls, robot at the origin facing +x.
ExplorationView MakeView(int segments) {
  const World& world = FullWorld();
  const std::vector<Wall> walls(world.walls.begin(), world.walls.begin() + segments);
  ExplorationView view;
  view.robot = Pose2{0.0, 0.0, 0.0};
  view.robot_covariance = Eigen::Matrix3d::Identity() * 1e-4;
  view.map_uncertainty = 0.0;
  for (int i = 0; i < segments; ++i) {
    view.segments.push_back(ToSegment(i + 1, walls[i], world.left[i], world.right[i]));
    view.map_uncertainty += M_PI * 1e-4;  // pi sqrt(det C_i) for C_i = 1e-4 I (2x2)
  }
  view.scan = CastScan(walls, Pose2{}, Lms200OneDegreeGeometry(), RayCastOptions{}, nullptr);
  return view;
}

// Candidate count -> (linear_steps, angular_steps), count = linear * angular - 1.
struct Steps {
  int candidates;
  int linear;
  int angular;
};
constexpr Steps kSteps[] = {{20, 3, 7}, {62, 3, 21}, {125, 6, 21}, {246, 13, 19}};

void RunDecide(benchmark::State& state, ExplorationMode mode, int candidates, int segments) {
  ExplorationOptions options;
  options.mode = mode;
  options.linear_steps = 0;
  for (const Steps& s : kSteps) {
    if (s.candidates == candidates) {
      options.linear_steps = s.linear;
      options.angular_steps = s.angular;
    }
  }
  if (!ValidateExplorationOptions(options).ok()) {
    state.SkipWithError("no valid (linear_steps, angular_steps) for this candidate count");
    return;
  }
  const ExplorationView view = MakeView(segments);
  const double travel = options.max_linear * options.observation_period;
  const ObservationPredictor predictor(view, options, travel);
  Suggestion last;
  for (auto _ : state) {
    ExplorationPlanner planner(options);
    last = planner.Decide(view);
    benchmark::DoNotOptimize(last);
  }
  state.counters["candidates"] = last.candidates;
  state.counters["feasible"] = last.feasible;
  state.counters["segments"] = static_cast<double>(view.segments.size());
  state.counters["frontiers"] = predictor.frontier_count();
  state.counters["occluders"] = predictor.occluder_count();
  state.SetLabel(BehaviourName(last.behaviour));
}

// Args: (candidate controls, segments).
void BM_PlannerDecide(benchmark::State& state) {
  RunDecide(state, ExplorationMode::kActive, static_cast<int>(state.range(0)),
            static_cast<int>(state.range(1)));
}
BENCHMARK(BM_PlannerDecide)
    ->ArgNames({"candidates", "segments"})
    ->ArgsProduct({{20, 62, 125, 246}, {10, 50, 100, 200, 400}})
    ->Unit(benchmark::kMillisecond);

// The baseline: wander mode (collision check and the straight-ahead rule, no prediction).
void BM_WanderDecide(benchmark::State& state) {
  RunDecide(state, ExplorationMode::kWander, static_cast<int>(state.range(0)),
            static_cast<int>(state.range(1)));
}
BENCHMARK(BM_WanderDecide)
    ->ArgNames({"candidates", "segments"})
    ->Args({20, 100})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace waymark::laser_slam

BENCHMARK_MAIN();

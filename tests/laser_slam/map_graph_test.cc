// One pose graph over a shared map's trajectories (map_graph.h): a loop the first robot left open
// is closed by the second robot, which drives from where the first one ended to where it
// started; one at a time (origin_smoothing.h) the first robot holds still and the second is bent
// to meet both ends.

#include "server/laser_slam/mapping/map_graph.h"
#include "server/laser_slam/mapping/map_graph_cache.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::PolylinePath;

// The nodes a robot driving `truth` keeps in its own frame (its first pose the origin), each step
// turned `heading_bias` rad to the left; scans from `first_scan` on, two per node.
std::vector<NodeView> Drifting(const std::vector<Pose2>& truth, double heading_bias,
                               std::uint64_t first_scan) {
  std::vector<NodeView> nodes;
  Pose2 own{};
  for (size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const Pose2 step = Relative(truth[i - 1], truth[i]);
      own = Compose(own, Pose2{step.x, step.y, step.theta + heading_bias});
    }
    NodeView node;
    node.scan = first_scan + 2 * i;
    node.stamp = static_cast<double>(node.scan);
    node.global = own;
    nodes.push_back(node);
  }
  return nodes;
}

OriginSample Observed(const NodeView& node, const Pose2& map_pose) {
  return OriginSample{node.scan, node.stamp, Compose(map_pose, Invert(node.global)), true,
                      map_pose};
}

double Distance(const Pose2& a, const Pose2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

// The first robot drives three sides of a 16 m x 8 m block with a heading bias (its map's end 2-3
// m off the truth); the second drives the fourth side, from the first one's end back to its
// start, on exact odometry. The follow matches the second robot against the map around it: at
// its start that is the first robot's drifted end, at its end the first robot's start (exact).
struct OpenLoop {
  std::vector<Pose2> truth_a, truth_b;
  std::vector<TiedTrajectory> map;
};

OpenLoop MakeOpenLoop() {
  OpenLoop w;
  w.truth_a = PolylinePath({{0.0, 0.0}, {16.0, 0.0}, {16.0, 8.0}, {0.0, 8.0}}, 0.25);
  w.truth_b = PolylinePath({{0.0, 8.0}, {0.0, 0.5}}, 0.25);
  TiedTrajectory a{Pose2{}, Drifting(w.truth_a, 0.002, 1), {}, {}};
  TiedTrajectory b{Pose2{}, Drifting(w.truth_b, 0.0, 1000), {}, {}};
  // Where the first robot's map has its end: the truth moved by its drift there.
  const Pose2 drift_at_end = Compose(a.nodes.back().global, Invert(w.truth_a.back()));
  for (size_t i = 0; i < w.truth_b.size(); i += 4) {
    const bool near_end_of_a = w.truth_b[i].y > 6.0;
    const bool near_start_of_a = w.truth_b[i].y < 2.5;
    if (near_end_of_a) b.samples.push_back(Observed(b.nodes[i], Compose(drift_at_end, w.truth_b[i])));
    if (near_start_of_a) b.samples.push_back(Observed(b.nodes[i], w.truth_b[i]));
  }
  b.origin = b.samples.front().origin;
  w.map = {a, b};
  return w;
}

TEST(MapGraphTest, ALoopTheFirstRobotLeftOpenIsClosedByTheSecond) {
  const OpenLoop w = MakeOpenLoop();
  const Pose2 a_end_before = w.map[0].nodes.back().global;
  const double drift = Distance(a_end_before, w.truth_a.back());
  ASSERT_GT(drift, 2.0);

  const std::vector<std::vector<OriginSample>> graph = SolveMapGraph(w.map);
  ASSERT_EQ(graph.size(), 2u);
  ASSERT_EQ(graph[0].size(), w.map[0].nodes.size());
  ASSERT_EQ(graph[1].size(), w.map[1].nodes.size());
  // The first robot's start is the map frame and stays; its end moves most of the way to the truth.
  EXPECT_LT(Distance(graph[0].front().map_pose, w.truth_a.front()), 1e-6);
  const double end_error = Distance(graph[0].back().map_pose, w.truth_a.back());
  EXPECT_LT(end_error, 0.35 * drift) << "drift " << drift;

  // One at a time the first robot holds still and the second is bent: worse, for both.
  const std::vector<NodeView> b_alone = NodesInMapFrame(w.map[1]);
  double bent = 0.0, joint = 0.0;
  for (size_t i = 0; i < w.truth_b.size(); ++i) {
    bent += Distance(b_alone[i].global, w.truth_b[i]);
    joint += Distance(graph[1][i].map_pose, w.truth_b[i]);
  }
  EXPECT_LT(joint, 0.5 * bent) << "mean " << joint / w.truth_b.size() << " against "
                               << bent / w.truth_b.size();
  // Every node's origin is its map pose (-) its own.
  for (size_t i = 0; i < graph[1].size(); ++i) {
    const Pose2 again = Compose(graph[1][i].origin, w.map[1].nodes[i].global);
    EXPECT_NEAR(again.x, graph[1][i].map_pose.x, 1e-9);
    EXPECT_NEAR(again.y, graph[1][i].map_pose.y, 1e-9);
  }
}

// A trajectory's own closures hold its shape: the same pull, but the first robot's session had
// a closure from its end to its start (at the relative pose its graph now gives them). Accepted
// by its own session, it is held as firmly as its chain: the first robot keeps its shape and the
// second is bent instead, as one at a time.
TEST(MapGraphTest, ATrajectorysOwnClosuresKeepItsShape) {
  OpenLoop w = MakeOpenLoop();
  GraphConstraint closure;
  closure.kind = GraphConstraint::Kind::kLoop;
  closure.from = 0;
  closure.to = static_cast<int>(w.map[0].nodes.size()) - 1;
  closure.sigma = Eigen::Vector3d(0.05, 0.05, 0.01);
  w.map[0].loops = {closure};
  const std::vector<std::vector<OriginSample>> graph = SolveMapGraph(w.map);
  const Pose2 end_before = w.map[0].nodes.back().global;
  const double drift = Distance(end_before, w.truth_a.back());
  EXPECT_LT(Distance(graph[0].back().map_pose, end_before), 0.1 * drift);
}

// With samples that agree with the map (each robot where the other's map has it), nothing moves;
// a trajectory tied in but not followed keeps its origin; an empty map gives nothing.
TEST(MapGraphTest, AgreeingSamplesMoveNothing) {
  const std::vector<Pose2> truth_a = PolylinePath({{0.0, 0.0}, {10.0, 0.0}}, 0.25);
  const std::vector<Pose2> truth_b = PolylinePath({{10.0, 0.5}, {2.0, 0.5}}, 0.25);
  const std::vector<Pose2> truth_c = PolylinePath({{5.0, -1.0}, {5.0, 3.0}}, 0.25);
  TiedTrajectory a{Pose2{}, Drifting(truth_a, 0.0, 1), {}, {}};
  TiedTrajectory b{Pose2{}, Drifting(truth_b, 0.0, 500), {}, {}};
  TiedTrajectory c{Pose2{1.0, 2.0, 0.3}, Drifting(truth_c, 0.0, 900), {}, {}};
  for (size_t i = 0; i < truth_b.size(); i += 5) b.samples.push_back(Observed(b.nodes[i], truth_b[i]));
  b.origin = b.samples.front().origin;
  const std::vector<TiedTrajectory> map{a, b, c};
  const std::vector<std::vector<OriginSample>> graph = SolveMapGraph(map);
  ASSERT_EQ(graph.size(), 3u);
  for (size_t t = 0; t < map.size(); t += 2) {  // a and c
    const std::vector<NodeView> before = NodesInMapFrame(map[t]);
    for (size_t i = 0; i < before.size(); ++i) {
      EXPECT_LT(Distance(graph[t][i].map_pose, before[i].global), 0.02) << t << " " << i;
    }
  }
  EXPECT_TRUE(SolveMapGraph({}).empty());
}

// The kept solution (map_graph_cache.h): reads of an unchanged map reuse it, and any change of
// an input the solver reads (a node's pose, a new sample, a closure) solves again, giving what a
// fresh solve gives.
bool SameSolution(const std::vector<std::vector<OriginSample>>& a,
                  const std::vector<std::vector<OriginSample>>& b) {
  if (a.size() != b.size()) return false;
  for (size_t t = 0; t < a.size(); ++t) {
    if (a[t].size() != b[t].size()) return false;
    for (size_t i = 0; i < a[t].size(); ++i) {
      const OriginSample &x = a[t][i], &y = b[t][i];
      if (x.scan != y.scan || x.map_pose.x != y.map_pose.x || x.map_pose.y != y.map_pose.y ||
          x.map_pose.theta != y.map_pose.theta || x.origin.x != y.origin.x ||
          x.origin.y != y.origin.y || x.origin.theta != y.origin.theta) {
        return false;
      }
    }
  }
  return true;
}

TEST(MapGraphCacheTest, AnUnchangedMapIsSolvedOnceAndAnyChangeSolvesAgain) {
  OpenLoop w = MakeOpenLoop();
  MapGraphCache cache;
  const auto first = cache.Solve(w.map);
  EXPECT_TRUE(SameSolution(first, SolveMapGraph(w.map)));
  EXPECT_TRUE(SameSolution(cache.Solve(w.map), first));
  EXPECT_TRUE(SameSolution(cache.Solve(w.map), first));
  EXPECT_EQ(cache.stats().solved, 1u);
  EXPECT_EQ(cache.stats().reused, 2u);

  // A node's points are not read by the solver: new points, the kept solution.
  w.map[1].nodes[3].points = std::make_shared<const PointCloud>();
  cache.Solve(w.map);
  EXPECT_EQ(cache.stats().solved, 1u);

  // Each input the solver reads, changed in turn: solved again, as a fresh solve.
  std::vector<std::function<void(OpenLoop*)>> changes = {
      [](OpenLoop* m) { m->map[0].nodes[10].global.x += 1e-6; },
      [](OpenLoop* m) { m->map[1].nodes[2].step_sigma.x() += 0.01; },
      [](OpenLoop* m) { m->map[1].samples.pop_back(); },
      [](OpenLoop* m) { m->map[1].samples[0].map_pose.theta += 0.001; },
      [](OpenLoop* m) {
        GraphConstraint closure;
        closure.kind = GraphConstraint::Kind::kLoop;
        closure.from = 0;
        closure.to = static_cast<int>(m->map[0].nodes.size()) - 1;
        closure.sigma = Eigen::Vector3d(0.05, 0.05, 0.01);
        m->map[0].loops = {closure};
      },
      [](OpenLoop* m) { m->map[0].loops[0].enabled = false; },
      [](OpenLoop* m) { m->map[1].origin.y += 0.5; },
      [](OpenLoop* m) { m->map[1].nodes.pop_back(); },
      [](OpenLoop* m) { m->map.pop_back(); },
  };
  std::uint64_t solved = 1;
  for (size_t c = 0; c < changes.size(); ++c) {
    changes[c](&w);
    const auto again = cache.Solve(w.map);
    EXPECT_EQ(cache.stats().solved, ++solved) << "change " << c;
    EXPECT_TRUE(SameSolution(again, SolveMapGraph(w.map))) << "change " << c;
    cache.Solve(w.map);
    EXPECT_EQ(cache.stats().solved, solved) << "change " << c << ", read again";
  }
}

}  // namespace
}  // namespace waymark::laser_slam

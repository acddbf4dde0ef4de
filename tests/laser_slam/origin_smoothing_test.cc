// A followed robot's origins from a pose graph of its nodes (origin_smoothing.h), against the
// interpolation between the follow's samples it replaces: a robot whose own odometry drifts
// (a heading bias and a scale error) and whose samples, one match each, are noisy.

#include "server/laser_slam/mapping/origin_smoothing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::PolylinePath;

// The nodes a robot driving `truth` keeps in its own frame, its steps 1 % long and turned
// `heading_bias` rad each to the left.
std::vector<NodeView> Drifting(const std::vector<Pose2>& truth, double heading_bias) {
  std::vector<NodeView> nodes;
  Pose2 own{};
  for (size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const Pose2 step = Relative(truth[i - 1], truth[i]);
      own = Compose(own, Pose2{step.x * 1.01, step.y * 1.01, step.theta + heading_bias});
    }
    NodeView node;
    node.scan = 2 * i + 1;
    node.stamp = static_cast<double>(i);
    node.global = own;
    nodes.push_back(node);
  }
  return nodes;
}

// What a follow-up match at node i observes: its true map-frame pose, off by the match's error.
OriginSample Match(const std::vector<NodeView>& nodes, const std::vector<Pose2>& truth, size_t i,
                   std::mt19937& rng, double sigma_xy, double sigma_theta) {
  std::normal_distribution<double> xy(0.0, sigma_xy), theta(0.0, sigma_theta);
  const Pose2 seen{truth[i].x + xy(rng), truth[i].y + xy(rng), truth[i].theta + theta(rng)};
  return OriginSample{nodes[i].scan, nodes[i].stamp, Compose(seen, Invert(nodes[i].global)), true,
                      seen};
}

// Mean distance of the map-frame poses (the origin at each node's stamp (+) its pose) from the
// truth, over nodes [first, last).
double MeanError(const std::vector<OriginSample>& origins, const std::vector<NodeView>& nodes,
                 const std::vector<Pose2>& truth, size_t first, size_t last) {
  double sum = 0.0;
  for (size_t i = first; i < last; ++i) {
    const Pose2 map = Compose(OriginAt(origins, nodes[i].stamp), nodes[i].global);
    sum += std::hypot(map.x - truth[i].x, map.y - truth[i].y);
  }
  return sum / static_cast<double>(last - first);
}

// The origins as they were: the samples interpolated (their origins from the nodes' poses).
std::vector<OriginSample> Interpolated(const std::vector<NodeView>& nodes,
                                       std::vector<OriginSample> samples) {
  RefreshOrigins(nodes, &samples);
  return samples;
}

// The tie at node 0 (right) and a follow-up match at every 5th node that `matched` keeps, each
// off by the match's error (seeded).
template <class Matched>
std::vector<OriginSample> Follow(const std::vector<NodeView>& nodes, const std::vector<Pose2>& truth,
                                 unsigned seed, double sigma_xy, double sigma_theta,
                                 Matched matched) {
  std::mt19937 rng(seed);
  std::vector<OriginSample> samples{
      OriginSample{nodes[0].scan, nodes[0].stamp, Compose(truth[0], Invert(nodes[0].global))}};
  for (size_t i = 5; i < nodes.size(); i += 5) {
    if (matched(i)) samples.push_back(Match(nodes, truth, i, rng, sigma_xy, sigma_theta));
  }
  return samples;
}

// Round a 20 x 10 m block: 60 m, 240 nodes.
std::vector<Pose2> Loop() {
  return PolylinePath({{0.0, 0.0}, {20.0, 0.0}, {20.0, 10.0}, {0.0, 10.0}, {0.0, 0.5}}, 0.25);
}

TEST(OriginSmoothingTest, ADetourOffTheMapIsBentAlongThePathNotAboutTheSessionOrigin) {
  // The robot is matched where the map is (its first and last 15 %) and nowhere in between: the
  // drift it gathered on the way round shows only at the end.
  const std::vector<Pose2> truth = Loop();
  const std::vector<NodeView> nodes = Drifting(truth, 0.002);
  const size_t n = nodes.size(), edge = n * 15 / 100;
  const std::vector<OriginSample> samples = Follow(
      nodes, truth, 7, 0.02, 0.004, [&](size_t i) { return i < edge || i >= n - edge; });
  const std::vector<OriginSample> smoothed = SmoothOrigins(nodes, samples);
  ASSERT_EQ(smoothed.size(), n);
  const double before = MeanError(Interpolated(nodes, samples), nodes, truth, edge, n - edge);
  const double after = MeanError(smoothed, nodes, truth, edge, n - edge);
  EXPECT_GT(before, 0.3) << "the synthetic drift is too small to test anything";
  // The drift here is a steady turn, which a graph of independent steps cannot undo exactly; it
  // still takes off about a third (0.45 -> 0.32 m).
  EXPECT_LT(after, 0.8 * before) << "interpolated " << before;
  // Where it was matched, it stays on the matches.
  EXPECT_LT(MeanError(smoothed, nodes, truth, 0, edge), 0.05);
  EXPECT_LT(MeanError(smoothed, nodes, truth, n - edge, n), 0.05);
}

TEST(OriginSmoothingTest, EachMatchsErrorIsAveragedNotFollowed) {
  // Matched all the way round, each match off by a few cm and half a degree: between two
  // samples the interpolated origin jumps by the second one's error; the graph weighs them
  // against the robot's own motion.
  const std::vector<Pose2> truth = Loop();
  const std::vector<NodeView> nodes = Drifting(truth, 0.0005);
  const std::vector<OriginSample> samples =
      Follow(nodes, truth, 11, 0.03, 0.01, [](size_t) { return true; });
  const double before = MeanError(Interpolated(nodes, samples), nodes, truth, 0, nodes.size());
  const double after = MeanError(SmoothOrigins(nodes, samples), nodes, truth, 0, nodes.size());
  // 0.030 -> 0.015 m.
  EXPECT_LT(after, 0.75 * before) << "interpolated " << before;
}

TEST(OriginSmoothingTest, TheTieAloneHoldsOneOrigin) {
  const std::vector<Pose2> truth = Loop();
  const std::vector<NodeView> nodes = Drifting(truth, 0.002);
  const Pose2 tie{3.0, -1.0, 0.7};
  const std::vector<OriginSample> smoothed =
      SmoothOrigins(nodes, {OriginSample{nodes[40].scan, nodes[40].stamp, tie}});
  ASSERT_EQ(smoothed.size(), nodes.size());
  for (const OriginSample& s : smoothed) {
    EXPECT_NEAR(s.origin.x, tie.x, 1e-6);
    EXPECT_NEAR(s.origin.y, tie.y, 1e-6);
    EXPECT_NEAR(s.origin.theta, tie.theta, 1e-6);
  }
}

TEST(OriginSmoothingTest, SamplesOnNoNodeAreKeptAsTheyWere) {
  const std::vector<Pose2> truth = Loop();
  const std::vector<NodeView> nodes = Drifting(truth, 0.002);
  const std::vector<OriginSample> off{OriginSample{2, 0.5, Pose2{1.0, 2.0, 0.3}}};  // even scan
  const std::vector<OriginSample> kept = SmoothOrigins(nodes, off);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].scan, 2u);
  EXPECT_DOUBLE_EQ(kept[0].origin.x, 1.0);
  EXPECT_TRUE(SmoothOrigins({}, off).size() == 1u);
  EXPECT_TRUE(SmoothOrigins(nodes, {}).empty());
}

}  // namespace
}  // namespace waymark::laser_slam

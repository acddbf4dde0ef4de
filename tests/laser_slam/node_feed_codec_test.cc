// The node feed's bytes (server/laser_slam/mapping/node_feed_codec.h): what one server publishes
// of a session's nodes comes back the same on the map's owner, and bytes that another server (or
// a damaged row) got wrong give DATA_LOSS, never nodes off the map or loops between nodes that do
// not exist. The fuzz target node_feed mutates the same bytes.

#include "server/laser_slam/mapping/node_feed_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace waymark::laser_slam {
namespace {

std::vector<NodeView> ThreeNodes() {
  std::vector<NodeView> nodes(3);
  for (int i = 0; i < 3; ++i) {
    nodes[i].scan = 5 * i + 2;
    nodes[i].stamp = 10.0 + 0.25 * i;
    nodes[i].global = Pose2{1.5 * i, -0.5 * i, 0.1 * i};
    nodes[i].step_sigma = Eigen::Vector3d(0.02 * i, 0.01, 0.003);
  }
  return nodes;
}

GraphConstraint Loop() {
  GraphConstraint loop;
  loop.kind = GraphConstraint::Kind::kLoop;
  loop.from = 2;
  loop.to = 0;
  loop.relative = Pose2{-3.0, 1.0, -0.2};
  loop.sigma = Eigen::Vector3d(0.05, 0.05, 0.01);
  loop.score = 0.8;
  return loop;
}

TEST(NodeFeedCodecTest, PosesAndLoopsComeBackAsWritten) {
  const std::vector<NodeView> nodes = ThreeNodes();
  absl::StatusOr<FeedPoses> back = DecodeFeedPoses(EncodeFeedPoses(nodes, {Loop()}));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->nodes.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(back->nodes[i].scan, nodes[i].scan);
    EXPECT_EQ(back->nodes[i].stamp, nodes[i].stamp);
    EXPECT_EQ(back->nodes[i].global.x, nodes[i].global.x);
    EXPECT_EQ(back->nodes[i].global.theta, nodes[i].global.theta);
    EXPECT_EQ(back->nodes[i].step_sigma, nodes[i].step_sigma);
    EXPECT_EQ(back->nodes[i].points, nullptr);  // points travel apart
  }
  ASSERT_EQ(back->loops.size(), 1u);
  EXPECT_EQ(back->loops[0].from, 2);
  EXPECT_EQ(back->loops[0].to, 0);
  EXPECT_EQ(back->loops[0].relative.y, 1.0);
  EXPECT_EQ(back->loops[0].sigma, Loop().sigma);
  EXPECT_EQ(back->loops[0].kind, GraphConstraint::Kind::kLoop);

  const PointCloud points = {{1.0f, 2.0f}, {-7.5f, 0.25f}, {0.0f, -30.0f}};
  absl::StatusOr<PointCloud> cloud = DecodeFeedPoints(EncodeFeedPoints(points));
  ASSERT_TRUE(cloud.ok()) << cloud.status();
  EXPECT_EQ(*cloud, points);
  // No points is a node too (a scan that gave none within range).
  ASSERT_TRUE(DecodeFeedPoints(EncodeFeedPoints({})).ok());
}

TEST(NodeFeedCodecTest, EveryTruncationAndWrongFieldIsDataLoss) {
  const std::string poses = EncodeFeedPoses(ThreeNodes(), {Loop()});
  const std::string points = EncodeFeedPoints({{1.0f, 2.0f}, {3.0f, 4.0f}});
  for (std::size_t n = 0; n < poses.size(); ++n) {
    EXPECT_EQ(DecodeFeedPoses(poses.substr(0, n)).status().code(), absl::StatusCode::kDataLoss)
        << n;
  }
  for (std::size_t n = 0; n < points.size(); ++n) {
    EXPECT_EQ(DecodeFeedPoints(points.substr(0, n)).status().code(), absl::StatusCode::kDataLoss)
        << n;
  }
  EXPECT_FALSE(DecodeFeedPoses(poses + "x").ok());  // bytes after the end
  EXPECT_FALSE(DecodeFeedPoses(points).ok());       // the other part
  EXPECT_FALSE(DecodeFeedPoints(poses).ok());

  // Scans not rising, a pose off the map, a NaN stamp, a loop to a node that is not there.
  std::vector<NodeView> bad = ThreeNodes();
  bad[2].scan = bad[1].scan;
  EXPECT_FALSE(DecodeFeedPoses(EncodeFeedPoses(bad, {})).ok());
  bad = ThreeNodes();
  bad[1].global.x = 1e12;
  EXPECT_FALSE(DecodeFeedPoses(EncodeFeedPoses(bad, {})).ok());
  bad = ThreeNodes();
  bad[0].stamp = std::nan("");
  EXPECT_FALSE(DecodeFeedPoses(EncodeFeedPoses(bad, {})).ok());
  GraphConstraint far = Loop();
  far.to = 3;
  EXPECT_FALSE(DecodeFeedPoses(EncodeFeedPoses(ThreeNodes(), {far})).ok());
  EXPECT_FALSE(DecodeFeedPoints(EncodeFeedPoints({{1e9f, 0.0f}})).ok());
}

}  // namespace
}  // namespace waymark::laser_slam

// The compact layouts of a database's memory (issue 34): keypoint positions in 16 bits, and
// k-d forests that store only their inner nodes.

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "server/crossing/compact_points.h"
#include "server/crossing/descriptor_store.h"
#include "server/crossing/kd_forest.h"
#include "server/crossing/l2_distance.h"

namespace waymark::crossing {
namespace {

TEST(CompactPointsTest, PositionsMoveByAtMostHalfAStep) {
  std::mt19937 rng(3);
  for (const float size : {320.f, 1000.f, 4096.f}) {
    std::uniform_real_distribution<float> coordinate(0.f, size - 0.01f);
    std::vector<cv::Point2f> points(500);
    for (cv::Point2f& p : points) p = {coordinate(rng), coordinate(rng)};
    const CompactPoints compact(points);
    ASSERT_EQ(compact.size(), points.size());
    // The finest power-of-two step at which the largest coordinate fits in 16 bits.
    const float step = size <= 512 ? 1.f / 128 : size <= 1024 ? 1.f / 64 : 1.f / 16;
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_LE(std::abs(compact[i].x - points[i].x), step / 2 + 1e-4f) << size;
      EXPECT_LE(std::abs(compact[i].y - points[i].y), step / 2 + 1e-4f) << size;
    }
    EXPECT_EQ(compact.memory_bytes(), points.size() * 4);
    // Stored positions store as themselves: a database reloaded from them matches as before.
    const std::vector<cv::Point2f> once = compact.ToVector();
    EXPECT_EQ(CompactPoints(once).ToVector(), once);
  }
}

TEST(CompactPointsTest, ValuesOutOfRangeAreClamped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const CompactPoints compact(std::vector<cv::Point2f>{{-3.f, nan}, {1e9f, 12.25f}});
  ASSERT_EQ(compact.size(), 2u);
  EXPECT_EQ(compact[0], cv::Point2f(0.f, 0.f));
  EXPECT_EQ(compact[1], cv::Point2f(65535.f, 12.f));  // a 1 px step at that range
  EXPECT_TRUE(CompactPoints().empty());
}

// Every indexed descriptor finds a neighbour at distance 0 (its own leaf is where an exact copy
// descends). Over more than 65,535 ids, so that the top nodes' left sizes do not fit their 16
// bits, and with runs of equal descriptors longer than a leaf (leaves that keep a node).
TEST(KdForestTest, LargeForestsWithWideNodesAndEqualRunsFindEveryDescriptor) {
  std::mt19937 rng(11);
  const uint32_t n = 140000;
  std::vector<uint8_t> data(static_cast<size_t>(n) * 128);
  for (uint32_t i = 0; i < n; ++i) {
    uint8_t* d = data.data() + static_cast<size_t>(i) * 128;
    if (i % 1000 < 30) {
      std::fill(d, d + 128, static_cast<uint8_t>(i / 1000));  // runs of 30 equal descriptors
    } else {
      for (int k = 0; k < 128; ++k) d[k] = static_cast<uint8_t>(rng() % 256);
    }
  }
  DescriptorStore store;
  store.Append(data.data(), n, 0);
  std::vector<uint32_t> ids(n);
  for (uint32_t i = 0; i < n; ++i) ids[i] = i;
  for (const int leaf_size : {1, 8}) {
    const KdForest forest(store, ids, 4, leaf_size, 7);
    ASSERT_EQ(forest.size(), n);
    std::vector<uint32_t> indexed = forest.ids();
    std::sort(indexed.begin(), indexed.end());
    EXPECT_EQ(indexed, ids);
    for (uint32_t i = 0; i < n; i += 97) {
      KnnList knn(2);
      forest.Search(store.Get(i), 16, &knn);
      ASSERT_FALSE(knn.items().empty()) << i;
      EXPECT_EQ(knn.items()[0].squared_distance, 0) << "leaf " << leaf_size << ", id " << i;
      EXPECT_EQ(SquaredL2(store.Get(knn.items()[0].id), store.Get(i)), 0);
    }
  }
}

}  // namespace
}  // namespace waymark::crossing

// The clock of the tie's rate-limited searches (search_clock.h): reads granted per scan, or per
// second of the robot's own stamps where that is more.

#include "server/laser_slam/mapping/search_clock.h"

#include <gtest/gtest.h>

#include <vector>

namespace waymark::laser_slam {
namespace {

NodeView Node(std::uint64_t scan, double stamp) {
  NodeView node;
  node.scan = scan;
  node.stamp = stamp;
  return node;
}

TEST(SearchClockTest, ScansAtTheirRateGrantWhatTheyGrant) {
  // A 10 Hz scanner, a node every 3 scans: 100 reads per scan beat 300 per second.
  const std::vector<NodeView> nodes{Node(1, 0.0), Node(4, 0.3), Node(7, 0.6)};
  const SearchClockRates rates{100.0, 300.0};
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 1.0, 7.0), 600.0);
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 2.5, 5.0), 250.0);
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 5.0, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 5.0, 2.0), 0.0);
  EXPECT_DOUBLE_EQ(ClockAfter(nodes, rates, 1.0, 250.0), 3.5);
  // Past the newest node (no stamp after it): per scan.
  EXPECT_DOUBLE_EQ(ClockAfter(nodes, rates, 6.0, 300.0), 9.0);
}

TEST(SearchClockTest, KeyframesSecondsApartGrantBySecond) {
  // One scan per node, 4 s apart, then a stretch at 10 Hz: 1,000 reads per second.
  const std::vector<NodeView> nodes{Node(1, 0.0), Node(2, 4.0), Node(3, 8.0), Node(13, 9.0)};
  const SearchClockRates rates{100.0, 1000.0};
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 1.0, 3.0), 8000.0);
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 1.5, 2.5), 4000.0);
  // 10 scans in 1 s: their 100 each are more than 1,000 per second.
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 3.0, 13.0), 1000.0);
  EXPECT_DOUBLE_EQ(ClockAfter(nodes, rates, 1.0, 6000.0), 2.5);
  EXPECT_DOUBLE_EQ(ClockAfter(nodes, rates, 1.0, 8500.0), 8.0);
  // The two are inverse to each other anywhere on the clock.
  for (const double from : {1.0, 1.7, 2.0, 2.9, 5.0}) {
    for (const double reads : {1.0, 500.0, 4000.0, 9000.0}) {
      const double to = ClockAfter(nodes, rates, from, reads);
      EXPECT_NEAR(ReadsGranted(nodes, rates, from, to), reads, 1e-6 * reads) << from << " " << reads;
    }
  }
  // Without a rate per second, only the scans count.
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, SearchClockRates{100.0, 0.0}, 1.0, 3.0), 200.0);
}

TEST(SearchClockTest, StampsThatDoNotAdvanceGrantPerScan) {
  const std::vector<NodeView> nodes{Node(1, 5.0), Node(2, 5.0), Node(3, 1.0), Node(4, 2.0)};
  const SearchClockRates rates{100.0, 1000.0};
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 1.0, 3.0), 200.0);
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 3.0, 4.0), 1000.0);
  EXPECT_DOUBLE_EQ(ReadsGranted({}, rates, 1.0, 3.0), 200.0);
  EXPECT_DOUBLE_EQ(ClockAfter({}, rates, 1.0, 150.0), 2.5);
}

}  // namespace
}  // namespace waymark::laser_slam

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

// A stretch of the clock: the reads the scans in (from, to] grant, and where `reads` from `from`
// bring the clock (`to`), checked both ways when the stretch grants anything.
struct Stretch {
  double from, to, reads;
};
void ExpectStretches(const std::vector<NodeView>& nodes, const SearchClockRates& rates,
                     const std::vector<Stretch>& stretches) {
  for (const Stretch& s : stretches) {
    EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, s.from, s.to), s.reads) << s.from << ".." << s.to;
    if (s.reads > 0) EXPECT_DOUBLE_EQ(ClockAfter(nodes, rates, s.from, s.reads), s.to);
  }
}

TEST(SearchClockTest, ScansAtTheirRateGrantWhatTheyGrant) {
  // A 10 Hz scanner, a node every 3 scans: 100 reads per scan beat 300 per second.
  const std::vector<NodeView> nodes{Node(1, 0.0), Node(4, 0.3), Node(7, 0.6)};
  const SearchClockRates rates{100.0, 300.0};
  // Past the newest node (no stamp after it): per scan, 6 -> 9.
  ExpectStretches(nodes, rates, {{1.0, 7.0, 600.0}, {2.5, 5.0, 250.0}, {1.0, 3.5, 250.0},
                                 {6.0, 9.0, 300.0}, {5.0, 5.0, 0.0}});
  EXPECT_DOUBLE_EQ(ReadsGranted(nodes, rates, 5.0, 2.0), 0.0);
}

TEST(SearchClockTest, KeyframesSecondsApartGrantBySecond) {
  // One scan per node, 4 s apart, then a stretch at 10 Hz: 1,000 reads per second.
  const std::vector<NodeView> nodes{Node(1, 0.0), Node(2, 4.0), Node(3, 8.0), Node(13, 9.0)};
  const SearchClockRates rates{100.0, 1000.0};
  // 3 -> 13: 10 scans in 1 s, their 100 each as much as 1,000 per second.
  ExpectStretches(nodes, rates, {{1.0, 3.0, 8000.0}, {1.5, 2.5, 4000.0}, {3.0, 13.0, 1000.0},
                                 {1.0, 2.5, 6000.0}, {1.0, 8.0, 8500.0}});
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
  // Stamps that stand still or run back grant per scan; 3 -> 4 runs forward 1 s.
  ExpectStretches(nodes, rates, {{1.0, 3.0, 200.0}, {3.0, 4.0, 1000.0}});
  ExpectStretches({}, rates, {{1.0, 3.0, 200.0}, {1.0, 2.5, 150.0}});
}

}  // namespace
}  // namespace waymark::laser_slam

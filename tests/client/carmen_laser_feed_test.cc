// CarmenLaserFeed: reordering within the lookahead, what is skipped and why, when the stamps count
// as broken, and restamping from the line order.
#include "client/datasets/carmen_laser_feed.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <string>
#include <vector>

#include "tests/client/carmen_test_log.h"
#include "tests/client/test_util.h"

namespace waymark::adapters {
namespace {

using testing::MakeLogWithStamps;
using testing::ScopedTempDir;

class CarmenLaserFeedTest : public ::testing::Test {
 protected:
  // Every stamp the feed returns for a log of these stamps.
  std::vector<double> Feed(const std::vector<double>& stamps, LaserFeedOptions options = {}) {
    const auto path = dir_.path() / "log.clf";
    std::ofstream(path) << "ODOM 0 0 0 0 0 0 1 nohost 1\n" << MakeLogWithStamps(stamps);
    auto reader = CarmenLogReader::Open(path.string());
    EXPECT_TRUE(reader.ok()) << reader.status();
    feed_ = std::make_unique<CarmenLaserFeed>(*std::move(reader), options);
    std::vector<double> out;
    CarmenRecord record;
    while (true) {
      auto more = feed_->Next(&record);
      EXPECT_TRUE(more.ok()) << more.status();
      if (!more.ok() || !*more) break;
      out.push_back(record.laser.stamp);
    }
    return out;
  }

  ScopedTempDir dir_;
  std::unique_ptr<CarmenLaserFeed> feed_;
};

TEST_F(CarmenLaserFeedTest, SkipsRepeatsAndLinesTooFarBackAndCountsEachKind) {
  // 1..100, then 5 (100 lines late: beyond the lookahead), then 100 again (a repeat).
  std::vector<double> stamps;
  for (int i = 1; i <= 100; ++i) stamps.push_back(i);
  stamps.push_back(5);
  stamps.push_back(100);
  const std::vector<double> fed = Feed(stamps);
  EXPECT_EQ(fed.size(), 100u);
  EXPECT_EQ(feed_->laser_lines(), 102);
  EXPECT_EQ(feed_->odometry_lines(), 1);
  EXPECT_EQ(feed_->skipped_stamps(), 2);
  EXPECT_EQ(feed_->repeated_stamps(), 1);
  EXPECT_EQ(feed_->last_repeated_stamp(), 100);
  EXPECT_FALSE(feed_->StampsBroken());
}

TEST_F(CarmenLaserFeedTest, MostLinesSkippedMeansBrokenStamps) {
  Feed({0, 0, 0, 0, 0});
  EXPECT_EQ(feed_->skipped_stamps(), 4);
  EXPECT_TRUE(feed_->StampsBroken());
  Feed({1, 2, 3, 3, 3});  // 2 of 5 skipped: not most
  EXPECT_FALSE(feed_->StampsBroken());
  Feed({1, 2, 2, 2});  // 2 of 4: half is not most
  EXPECT_FALSE(feed_->StampsBroken());
}

TEST_F(CarmenLaserFeedTest, RestampUsesTheLineOrderAndTheRate) {
  LaserFeedOptions options;
  options.restamp_rate_hz = 4;
  EXPECT_EQ(Feed({-0.4, -0.9, 4294967295.0, 4294967295.0, 0}, options),
            (std::vector<double>{0, 0.25, 0.5, 0.75, 1.0}));
  EXPECT_TRUE(feed_->restamped());
  EXPECT_EQ(feed_->skipped_stamps(), 0);
  EXPECT_EQ(feed_->reordered_lines(), 0);
  EXPECT_FALSE(feed_->StampsBroken());
}

}  // namespace
}  // namespace waymark::adapters

namespace waymark::adapters {
namespace {

// Five FLASER lines whose odometry x is the line's index (and the laser pose 10 beyond it).
std::string LogWithIndexedOdometry() {
  std::string log = "ODOM 0 0 0 0 0 0 1 nohost 1\n";
  for (int i = 0; i < 5; ++i) {
    log += "FLASER 3 1 1 1 " + std::to_string(10 + i) + " 0 0 " + std::to_string(i) +
           " 0 0 " + std::to_string(i + 1) + " nohost " + std::to_string(i + 1) + "\n";
  }
  return log;
}

// What each laser line returned carries: (stamp, odometry x, laser x).
std::vector<std::array<double, 3>> FeedLagged(const std::string& path, LaserFeedOptions options) {
  auto reader = CarmenLogReader::Open(path);
  EXPECT_TRUE(reader.ok()) << reader.status();
  CarmenLaserFeed feed(*std::move(reader), options);
  std::vector<std::array<double, 3>> out;
  CarmenRecord record;
  while (true) {
    auto more = feed.Next(&record);
    EXPECT_TRUE(more.ok()) << more.status();
    if (!more.ok() || !*more) break;
    out.push_back({record.laser.stamp, record.laser.odom_pose.x, record.laser.laser_pose.x});
  }
  return out;
}

TEST(CarmenLaserFeedLagTest, EachLineTakesTheOdometryOfTheLineLagLater) {
  ScopedTempDir dir;
  const auto path = (dir.path() / "log.clf").string();
  std::ofstream(path) << LogWithIndexedOdometry();
  for (const bool restamped : {false, true}) {
    LaserFeedOptions options;
    options.restamp_rate_hz = restamped ? 2.0 : 0.0;
    for (const int lag : {-2, -1, 0, 1, 3}) {
      options.odometry_lag_scans = lag;
      const auto fed = FeedLagged(path, options);
      ASSERT_EQ(fed.size(), 5u) << lag;
      for (int i = 0; i < 5; ++i) {
        const int from = std::clamp(i + lag, 0, 4);
        EXPECT_EQ(fed[i][0], restamped ? i / 2.0 : i + 1.0) << "stamps stay the line's own";
        EXPECT_EQ(fed[i][1], from) << "lag " << lag << " line " << i;
        EXPECT_EQ(fed[i][2], 10 + from) << "the laser pose moves with its odometry";
      }
    }
  }
}

}  // namespace
}  // namespace waymark::adapters

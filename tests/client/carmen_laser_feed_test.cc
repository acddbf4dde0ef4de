// CarmenLaserFeed: reordering within the lookahead, what is skipped and why, when the stamps count
// as broken, and restamping from the line order.
#include "client/datasets/carmen_laser_feed.h"

#include <gtest/gtest.h>

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

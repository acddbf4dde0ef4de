#include "server/visual_slam/coarse_matching.h"

#include <gtest/gtest.h>

namespace waymark::visual_slam {
namespace {

cv::Mat Descriptor(std::initializer_list<int> flipped_bits, uint8_t base = 0) {
  cv::Mat d(1, 32, CV_8U, cv::Scalar(base));
  for (int bit : flipped_bits) d.at<uint8_t>(0, bit / 8) ^= static_cast<uint8_t>(1 << (bit % 8));
  return d;
}

TEST(CoarseMatchTest, KeepsPairsBelowDeltaThatPassTheRatioTest) {
  cv::Mat train;
  train.push_back(Descriptor({}, 0x00));     // 0
  train.push_back(Descriptor({}, 0xFF));     // 1: 256 bits from 0
  train.push_back(Descriptor({}, 0x0F));     // 2: 128 bits from 0
  cv::Mat query;
  query.push_back(Descriptor({1, 2, 3}));          // 3 bits from train 0
  query.push_back(Descriptor({}, 0xF7));           // 32 bits from 1 (0xF7 vs 0xFF)
  query.push_back(Descriptor({}, 0x07));           // 32 from 2 (0x07 vs 0x0F), 96 from 0
  std::vector<DescriptorMatch> matches = CoarseMatch(query, train, /*delta=*/40, /*ratio=*/0.8);
  ASSERT_EQ(matches.size(), 3u);
  EXPECT_EQ(matches[0].query, 0);
  EXPECT_EQ(matches[0].train, 0);
  EXPECT_EQ(matches[0].distance, 3);
  EXPECT_EQ(matches[1].train, 1);
  EXPECT_EQ(matches[1].distance, 32);
  EXPECT_EQ(matches[2].train, 2);

  // delta is strict (eq 8: distance < delta).
  matches = CoarseMatch(query, train, /*delta=*/32, /*ratio=*/0.8);
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].query, 0);
}

TEST(CoarseMatchTest, AmbiguousAndDuplicateMatchesAreDropped) {
  cv::Mat train;
  train.push_back(Descriptor({0}));
  train.push_back(Descriptor({1}));  // the query below is 1 bit from both: ambiguous
  cv::Mat query;
  query.push_back(Descriptor({}));
  EXPECT_TRUE(CoarseMatch(query, train, 64, 0.8).empty());

  cv::Mat one_train = Descriptor({});
  cv::Mat two_queries;
  two_queries.push_back(Descriptor({5, 6}));
  two_queries.push_back(Descriptor({7}));
  std::vector<DescriptorMatch> matches = CoarseMatch(two_queries, one_train, 64, 0.8);
  ASSERT_EQ(matches.size(), 1u);  // the train row keeps its closest query
  EXPECT_EQ(matches[0].query, 1);
  EXPECT_TRUE(CoarseMatch(cv::Mat(), one_train, 64, 0.8).empty());
}

}  // namespace
}  // namespace waymark::visual_slam

#include "server/crossing/view_matching.h"

#include <random>

#include <gtest/gtest.h>

#include "server/crossing/descriptor_index.h"
#include "server/crossing/l2_distance.h"
#include "tests/support/random_descriptors.h"

namespace waymark::crossing {
namespace {

using waymark::testing::Perturb;
using waymark::testing::RandomDescriptors;

TEST(RatioTest, EuclideanNotSquared) {
  // dis_a = 3, dis_b = 10: 3 < 0.32 * 10 passes; dis_a = 3.3 does not.
  EXPECT_TRUE(PassesRatio(9, 100, 0.32));
  EXPECT_FALSE(PassesRatio(11, 100, 0.32));  // sqrt(11) = 3.32 > 3.2
  EXPECT_FALSE(PassesRatio(100, 100, 1.0));  // strict inequality
}

TEST(L2Test, SquaredDistanceByHand) {
  uint8_t a[128] = {}, b[128] = {};
  a[0] = 3;
  b[0] = 0;
  a[127] = 0;
  b[127] = 4;
  EXPECT_EQ(SquaredL2(a, b), 25);
  for (int i = 0; i < 128; ++i) a[i] = 255, b[i] = 0;
  EXPECT_EQ(SquaredL2(a, b), 128 * 255 * 255);
}

TEST(MatchViewExactTest, AcceptsDistinctiveRejectsAmbiguous) {
  std::mt19937 rng(1);
  DescriptorIndex index(IndexOptions{});
  const cv::Mat view = RandomDescriptors(50, &rng);
  index.Add(view.ptr<uint8_t>(), 50, 0);
  // Query 0: a near copy of descriptor 7 -> distinctive -> matches descriptor 7.
  // Query 1: the average of descriptors 3 and 4 -> equidistant -> ambiguous -> no match.
  cv::Mat query(2, 128, CV_8U);
  Perturb(view.row(7), 2, &rng).copyTo(query.row(0));
  for (int k = 0; k < 128; ++k) {
    query.at<uint8_t>(1, k) = (view.at<uint8_t>(3, k) + view.at<uint8_t>(4, k)) / 2;
  }
  const auto matches = MatchViewExact(query, index.store(), ViewSpan{0, 50}, 0.32);
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].query_index, 0);
  EXPECT_EQ(matches[0].train_id, 7u);
}

TEST(MatchViewExactTest, SingleDescriptorViewHasNoSecondNeighbour) {
  std::mt19937 rng(2);
  DescriptorIndex index(IndexOptions{});
  const cv::Mat view = RandomDescriptors(1, &rng);
  index.Add(view.ptr<uint8_t>(), 1, 0);
  EXPECT_TRUE(MatchViewExact(view, index.store(), ViewSpan{0, 1}, 1.0).empty());
}

// The global index must give (nearly) the same per-view counts as matching each view exactly,
// also when it was grown view by view (several levels).
TEST(MatchAllViewsTest, AgreesWithExactPerViewMatching) {
  std::mt19937 rng(3);
  IndexOptions options;
  DescriptorIndex index(options);
  std::vector<ViewSpan> spans;
  std::vector<cv::Mat> views;
  for (uint32_t v = 0; v < 60; ++v) {
    views.push_back(RandomDescriptors(150, &rng));
    const uint32_t first = index.Add(views.back().ptr<uint8_t>(), 150, v);
    spans.push_back(ViewSpan{first, 150});
  }
  EXPECT_GT(index.levels(), 1u);
  // Query: 40 perturbed descriptors of view 5, 30 of view 17, 30 random.
  cv::Mat query;
  cv::vconcat(std::vector<cv::Mat>{Perturb(views[5].rowRange(0, 40), 20, &rng),
                                   Perturb(views[17].rowRange(50, 80), 20, &rng),
                                   RandomDescriptors(30, &rng)},
              query);
  const ViewMatches all = MatchAllViews(query, index, spans, 0.32, true);
  int total_exact = 0, total_index = 0, agree = 0;
  for (uint32_t v = 0; v < spans.size(); ++v) {
    const int exact = static_cast<int>(MatchViewExact(query, index.store(), spans[v], 0.32).size());
    const int via_index = all.count(v) ? static_cast<int>(all.at(v).size()) : 0;
    total_exact += exact;
    total_index += via_index;
    agree += std::min(exact, via_index);
  }
  EXPECT_EQ(total_exact, 70);  // the planted matches, and nothing random
  EXPECT_GE(agree, 0.95 * total_exact);
  EXPECT_LE(total_index, total_exact);  // the index never invents a match
  ASSERT_TRUE(all.count(5));
  ASSERT_TRUE(all.count(17));
  EXPECT_GE(all.at(5).size(), 38u);
  EXPECT_GE(all.at(17).size(), 28u);
}

TEST(MatchAllViewsTest, ForestSetOverSomeViewsMatchesOnlyThose) {
  std::mt19937 rng(4);
  DescriptorIndex index(IndexOptions{});
  std::vector<ViewSpan> spans;
  std::vector<cv::Mat> views;
  for (uint32_t v = 0; v < 4; ++v) {
    views.push_back(RandomDescriptors(100, &rng));
    spans.push_back(ViewSpan{index.Add(views.back().ptr<uint8_t>(), 100, v), 100});
  }
  const cv::Mat query = Perturb(views[2].rowRange(0, 20), 10, &rng);
  ForestSet some(index.store(), IndexOptions{});
  for (uint32_t v : {0u, 1u, 3u}) some.Add(IdRange(spans[v].first, spans[v].count));
  EXPECT_EQ(MatchAllViews(query, some, spans, 0.32, true).count(2), 0u);
  some.Add(IdRange(spans[2].first, spans[2].count));
  EXPECT_EQ(MatchAllViews(query, some, spans, 0.32, true).at(2).size(), 20u);
}

TEST(DescriptorIndexTest, EveryDescriptorFindsItselfAcrossLevels) {
  std::mt19937 rng(5);
  DescriptorIndex index(IndexOptions{});
  cv::Mat all;
  for (uint32_t v = 0; v < 20; ++v) {
    const cv::Mat d = RandomDescriptors(64, &rng);
    index.Add(d.ptr<uint8_t>(), 64, v);
    all.push_back(d);
  }
  EXPECT_GT(index.levels(), 1u);
  EXPECT_EQ(index.forests().size(), 20u * 64);
  for (int i = 0; i < all.rows; i += 37) {
    KnnList knn(4);
    index.Search(all.ptr<uint8_t>(i), &knn);
    ASSERT_FALSE(knn.items().empty());
    EXPECT_EQ(knn.items()[0].squared_distance, 0);
    EXPECT_EQ(knn.items()[0].id, static_cast<uint32_t>(i));
  }
}

TEST(DescriptorIndexTest, SameAdditionsGiveTheSameSearchResults) {
  // What a restart relies on: replaying the additions (deferred, then built once, as the server
  // loads) rebuilds the forests that were built along the way.
  std::mt19937 rng(8);
  std::vector<cv::Mat> views;
  for (int v = 0; v < 30; ++v) views.push_back(RandomDescriptors(50 + v, &rng));
  DescriptorIndex a(IndexOptions{}), b(IndexOptions{});
  for (uint32_t v = 0; v < views.size(); ++v) {
    a.Add(views[v].ptr<uint8_t>(), views[v].rows, v);
    b.Add(views[v].ptr<uint8_t>(), views[v].rows, v, /*defer_build=*/true);
  }
  b.BuildPending();
  ASSERT_EQ(a.levels(), b.levels());
  EXPECT_GT(a.levels(), 1u);
  const cv::Mat query = RandomDescriptors(50, &rng);
  for (int i = 0; i < query.rows; ++i) {
    KnnList ka(8), kb(8);
    a.Search(query.ptr<uint8_t>(i), &ka);
    b.Search(query.ptr<uint8_t>(i), &kb);
    ASSERT_EQ(ka.items().size(), kb.items().size());
    for (size_t k = 0; k < ka.items().size(); ++k) EXPECT_EQ(ka.items()[k].id, kb.items()[k].id);
  }
}

}  // namespace
}  // namespace waymark::crossing

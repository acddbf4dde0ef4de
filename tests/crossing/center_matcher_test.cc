// The clustering's matcher must count exactly what MatchViewExact counts against every centre, and
// the clustering built on it must be the paper's quadratic clustering, ties included.

#include "server/crossing/center_matcher.h"

#include <random>

#include <gtest/gtest.h>

#include "server/crossing/decision.h"
#include "server/crossing/enrollment.h"
#include "server/crossing/view_database.h"
#include "tests/support/random_descriptors.h"

namespace waymark::crossing {
namespace {

using waymark::testing::Perturb;
using waymark::testing::RandomDescriptors;

std::vector<int> ExactCounts(const cv::Mat& query, const DescriptorStore& store,
                             const std::vector<ViewSpan>& centers, double ratio) {
  std::vector<int> counts;
  for (ViewSpan c : centers) {
    counts.push_back(static_cast<int>(MatchViewExact(query, store, c, ratio).size()));
  }
  return counts;
}

// SIFT-like descriptors: sparse, most bins small, so that near copies and the balls of the
// matcher behave as on real images (uniform bytes are all about equally far apart).
cv::Mat SiftLike(int n, std::mt19937* rng) {
  cv::Mat d(n, 128, CV_8U);
  std::uniform_int_distribution<int> big(40, 160), small(0, 12), pick(0, 3);
  for (int r = 0; r < n; ++r) {
    for (int k = 0; k < 128; ++k) d.at<uint8_t>(r, k) = pick(*rng) == 0 ? big(*rng) : small(*rng);
  }
  return d;
}

class CenterMatcherTest : public ::testing::TestWithParam<double> {};

TEST_P(CenterMatcherTest, CountsEqualExactMatchingOfEveryCenter) {
  const double ratio = GetParam();
  std::mt19937 rng(11);
  DescriptorStore store;
  CenterMatcher matcher(store);
  std::vector<ViewSpan> centers;
  std::vector<cv::Mat> views;
  auto add = [&](const cv::Mat& d) {
    views.push_back(d);
    const uint32_t first = store.Append(d.ptr<uint8_t>(), d.rows, views.size() - 1);
    centers.push_back(ViewSpan{first, static_cast<uint32_t>(d.rows)});
    matcher.Add(centers.back());
  };
  for (int v = 0; v < 30; ++v) add(SiftLike(60 + 7 * v, &rng));
  // Degenerate centres: a single descriptor (no second neighbour), exact duplicates (s(x) = 0), an
  // empty one.
  add(SiftLike(1, &rng));
  cv::Mat twice;
  cv::vconcat(views[3].rowRange(0, 20), views[3].rowRange(0, 20), twice);
  add(twice);
  add(cv::Mat(0, 128, CV_8U));

  // Queries: near copies of several centres at growing distances (around the ratio's edge),
  // copies of the duplicated rows (nearest == second nearest: never a match), midpoints of two
  // descriptors of one centre (a tie between its two nearest), and unrelated descriptors.
  std::vector<cv::Mat> parts;
  for (int amplitude : {2, 6, 12, 20, 30, 45}) {
    parts.push_back(Perturb(views[amplitude % 30].rowRange(0, 25), amplitude, &rng));
  }
  parts.push_back(views[3].rowRange(0, 10).clone());
  cv::Mat midpoints(10, 128, CV_8U);
  for (int r = 0; r < 10; ++r) {
    for (int k = 0; k < 128; ++k) {
      midpoints.at<uint8_t>(r, k) =
          (views[7].at<uint8_t>(2 * r, k) + views[7].at<uint8_t>(2 * r + 1, k)) / 2;
    }
  }
  parts.push_back(midpoints);
  parts.push_back(SiftLike(40, &rng));
  cv::Mat query;
  cv::vconcat(parts, query);

  const std::vector<int> exact = ExactCounts(query, store, centers, ratio);
  EXPECT_EQ(matcher.CountMatches(query, ratio), exact);
  int total = 0;
  for (int m : exact) total += m;
  EXPECT_GT(total, 20);  // the planted matches are there: the comparison is not of zeros
}

INSTANTIATE_TEST_SUITE_P(Ratios, CenterMatcherTest, ::testing::Values(0.32, 0.6, 0.8, 1.0));

// The projection basis is refitted as centres arrive; counts must not depend on when.
TEST(CenterMatcherRefitTest, CountsAfterEveryAddEqualExactMatching) {
  std::mt19937 rng(12);
  DescriptorStore store;
  CenterMatcher matcher(store);
  std::vector<ViewSpan> centers;
  for (int v = 0; v < 40; ++v) {
    const cv::Mat d = SiftLike(50 + v, &rng);
    centers.push_back(
        ViewSpan{store.Append(d.ptr<uint8_t>(), d.rows, v), static_cast<uint32_t>(d.rows)});
    matcher.Add(centers.back());
    cv::Mat query;
    cv::vconcat(Perturb(d.rowRange(0, 10), 8, &rng), SiftLike(10, &rng), query);
    ASSERT_EQ(matcher.CountMatches(query, 0.32), ExactCounts(query, store, centers, 0.32))
        << "after centre " << v;
  }
}

void ExpectSameClusters(const std::vector<ClusterEntry>& a, const std::vector<ClusterEntry>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t c = 0; c < a.size(); ++c) {
    EXPECT_EQ(a[c].center, b[c].center) << "cluster " << c;
    EXPECT_EQ(a[c].members, b[c].members) << "cluster " << c;
  }
}

// Views made of parts of earlier views, so that later views match several centres, some with
// exactly equal counts (the first centre must win, as in the paper's argmax), some just below and
// at the threshold.
TEST(ClusteringTest, FastClusteringEqualsQuadraticWithTies) {
  std::mt19937 rng(13);
  std::vector<cv::Mat> bases;
  for (int b = 0; b < 8; ++b) bases.push_back(SiftLike(80, &rng));
  std::vector<cv::Mat> views;
  for (int b = 0; b < 8; ++b) views.push_back(bases[b]);
  std::uniform_int_distribution<int> base(0, 7), take(3, 9);
  for (int v = 0; v < 60; ++v) {
    // k rows from one base and the same k rows from another: a tie when both are centres.
    const int a = base(rng), b = base(rng), k = take(rng);
    const int offset = (v * 11) % 60;
    std::vector<cv::Mat> parts = {Perturb(bases[a].rowRange(offset, offset + k), 4, &rng),
                                  Perturb(bases[b].rowRange(offset, offset + k), 4, &rng),
                                  SiftLike(30, &rng)};
    cv::Mat d;
    cv::vconcat(parts, d);
    views.push_back(d);
  }
  ViewDatabase db;
  for (size_t i = 0; i < views.size(); ++i) {
    ImageFeatures f;
    f.descriptors = views[i];
    EnrollView(&db, static_cast<int64_t>(i) + 1, 1, 0, f);
  }
  const std::vector<ClusterEntry> reference = QuadraticClusters(db, ClusterOptions{});
  ExpectSameClusters(db.clusters(), reference);
  ExpectSameClusters(db.ComputeClusters(ClusterOptions{}), reference);
  EXPECT_GT(reference.size(), 8u);  // some views started clusters...
  EXPECT_LT(reference.size(), views.size() - 10);  // ...and many joined one

  // Some view's best count is shared by two centres (the tie this test is about).
  int ties = 0;
  std::vector<ViewSpan> centers;
  for (const ClusterEntry& c : reference) centers.push_back(db.spans()[c.center]);
  for (uint32_t s = 0; s < db.views().size(); ++s) {
    const std::vector<int> counts =
        ExactCounts(db.Descriptors(s), db.index().store(), centers, 0.32);
    const int best = AssignCluster(counts, 5);
    if (best >= 0 && std::count(counts.begin(), counts.end(), counts[best]) > 1) ++ties;
  }
  EXPECT_GT(ties, 0);
}

}  // namespace
}  // namespace waymark::crossing

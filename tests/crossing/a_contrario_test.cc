// The a-contrario acceptance rule (a_contrario.h): random correspondences are rarely meaningful
// (the false-alarm rate stays under its nominal bound), a rigid scene seen from two places is
// meaningful by far, and the same inlier count means less on more tentative matches or a larger
// image.
#include "server/crossing/a_contrario.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include <opencv2/calib3d.hpp>

#include "server/crossing/geometric_verification.h"

namespace waymark::crossing {
namespace {

constexpr int kWidth = 320, kHeight = 240;

// Evidence of the RANSAC geometry of `q` <-> `v` (as the retrieval mode computes it).
EpipolarEvidence Evidence(const std::vector<cv::Point2f>& q, const std::vector<cv::Point2f>& v,
                          double tests = 1.0) {
  const std::optional<cv::Matx33d> f = EstimateFundamental(q, v, VerificationOptions{});
  if (!f) return {};
  return AContrarioEvidence(EpipolarResiduals(*f, q, v), cv::Size(kWidth, kHeight), tests);
}

cv::Point2f RandomPoint(std::mt19937& rng) {
  std::uniform_real_distribution<float> x(0, kWidth), y(0, kHeight);
  return {x(rng), y(rng)};
}

TEST(AContrarioTest, BinomialCoefficients) {
  EXPECT_NEAR(Log10Binomial(10, 3), std::log10(120.0), 1e-9);
  EXPECT_NEAR(Log10Binomial(7, 7), 0.0, 1e-12);
  EXPECT_TRUE(std::isinf(Log10Binomial(3, 5)));
}

TEST(AContrarioTest, RandomCorrespondencesStayUnderTheNominalFalseAlarmRate) {
  // H0: tentative matches that are pure chance. With the threshold at NFA < 0.1 per trial (one
  // test), at most about 10 % of the trials may pass; the bound is loose, so far fewer do.
  std::mt19937 rng(7);
  int meaningful_01 = 0, meaningful_1 = 0;
  constexpr int kTrials = 150;
  for (int t = 0; t < kTrials; ++t) {
    const int n = 12 + t % 80;
    std::vector<cv::Point2f> q, v;
    for (int i = 0; i < n; ++i) {
      q.push_back(RandomPoint(rng));
      v.push_back(RandomPoint(rng));
    }
    const EpipolarEvidence e = Evidence(q, v);
    meaningful_01 += e.log10_nfa < -1.0;
    meaningful_1 += e.log10_nfa < 0.0;
  }
  EXPECT_LE(meaningful_01, kTrials / 10);
  EXPECT_LE(meaningful_1, kTrials);  // NFA < 1: at most one false alarm per trial on average
  EXPECT_LE(meaningful_01, meaningful_1);
  RecordProperty("meaningful_at_0.1", meaningful_01);
  RecordProperty("meaningful_at_1", meaningful_1);
  std::cout << "random trials meaningful: " << meaningful_01 << " at NFA < 0.1, " << meaningful_1 << " at NFA < 1 of " << kTrials << "\n";
}

// A rigid scene seen by two cameras 1.5 m apart, with `outliers` random pairs mixed in.
void TwoViews(int inliers, int outliers, std::vector<cv::Point2f>* q,
              std::vector<cv::Point2f>* v, double noise_px = 0.5) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> x(-4, 4), y(-2, 2), z(6, 20);
  std::normal_distribution<double> noise(0, noise_px);
  const cv::Matx33d k(250, 0, kWidth / 2.0, 0, 250, kHeight / 2.0, 0, 0, 1);
  const double yaw = 0.15;
  const cv::Matx33d r(std::cos(yaw), 0, std::sin(yaw), 0, 1, 0, -std::sin(yaw), 0, std::cos(yaw));
  const cv::Vec3d t(1.5, 0.0, 0.3);
  while (static_cast<int>(q->size()) < inliers) {
    const cv::Vec3d p(x(rng), y(rng), z(rng));
    const cv::Vec3d a = k * p;
    const cv::Vec3d b = k * (r * p + t);
    if (b[2] <= 0) continue;
    const cv::Point2f pa(a[0] / a[2] + noise(rng), a[1] / a[2] + noise(rng));
    const cv::Point2f pb(b[0] / b[2] + noise(rng), b[1] / b[2] + noise(rng));
    if (pa.x < 0 || pa.x >= kWidth || pa.y < 0 || pa.y >= kHeight || pb.x < 0 ||
        pb.x >= kWidth || pb.y < 0 || pb.y >= kHeight) {
      continue;
    }
    q->push_back(pa);
    v->push_back(pb);
  }
  for (int i = 0; i < outliers; ++i) {
    q->push_back(RandomPoint(rng));
    v->push_back(RandomPoint(rng));
  }
}

TEST(AContrarioTest, ARigidSceneFromAnotherPlaceIsMeaningfulByFar) {
  std::vector<cv::Point2f> q, v;
  TwoViews(30, 30, &q, &v);
  const EpipolarEvidence e = Evidence(q, v, /*tests=*/24);
  EXPECT_LT(e.log10_nfa, -5.0);
  EXPECT_GE(e.inliers, 28);
  EXPECT_LE(e.inliers, 34);  // a few random pairs may fall near their epipolar lines
  EXPECT_LT(e.residual_px, 3.0);
}

TEST(AContrarioTest, TheSameInliersMeanLessAmongMoreTentativeMatches) {
  std::vector<cv::Point2f> q, v;
  TwoViews(15, 10, &q, &v);
  const EpipolarEvidence few = Evidence(q, v);
  std::vector<cv::Point2f> q2, v2;
  TwoViews(15, 120, &q2, &v2);
  const EpipolarEvidence many = Evidence(q2, v2);
  EXPECT_LT(few.log10_nfa, many.log10_nfa);
  // And more tests (a longer shortlist) raise the NFA by exactly their log.
  std::vector<double> residuals = EpipolarResiduals(*EstimateFundamental(q, v, {}), q, v);
  const EpipolarEvidence one = AContrarioEvidence(residuals, cv::Size(kWidth, kHeight), 1);
  const EpipolarEvidence hundred = AContrarioEvidence(residuals, cv::Size(kWidth, kHeight), 100);
  EXPECT_NEAR(hundred.log10_nfa - one.log10_nfa, 2.0, 1e-9);
}

TEST(AContrarioTest, TooFewMatchesOrNoImageGiveNoEvidence) {
  EXPECT_EQ(AContrarioEvidence({0.1, 0.2, 0.3}, cv::Size(kWidth, kHeight), 1).inliers, 0);
  EXPECT_EQ(AContrarioEvidence(std::vector<double>(20, 0.5), cv::Size(0, 0), 1).inliers, 0);
  std::vector<double> bad(20, std::nan(""));
  EXPECT_EQ(AContrarioEvidence(bad, cv::Size(kWidth, kHeight), 1).inliers, 0);
}

TEST(AContrarioTest, ResidualsAreZeroOnTheEpipolarGeometryItself) {
  std::vector<cv::Point2f> q, v;
  TwoViews(40, 0, &q, &v, /*noise_px=*/0.0);
  const cv::Mat f = cv::findFundamentalMat(q, v, cv::FM_8POINT);
  const std::vector<double> r = EpipolarResiduals(cv::Matx33d(f.ptr<double>()), q, v);
  for (double d : r) EXPECT_LT(d, 0.05);
}

}  // namespace
}  // namespace waymark::crossing

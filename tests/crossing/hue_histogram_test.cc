#include "server/crossing/hue_histogram.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace waymark::crossing {
namespace {

constexpr double kDeg = M_PI / 180.0;

TEST(HsiHueTest, PrimaryAndSecondaryColoursByHand) {
  // Pure red: numerator (255 + 255), denominator 2*sqrt(255^2 + 0) -> cos = 1 -> 0 degrees.
  EXPECT_NEAR(*HsiHue(255, 0, 0), 0.0, 1e-9);
  // Pure green: ((-255) + 0) / (2 * sqrt(255^2 + 0)) = -0.5 -> 120 degrees; B = G? no, B < G.
  EXPECT_NEAR(*HsiHue(0, 255, 0), 120 * kDeg, 1e-9);
  // Pure blue: (0 + (-255)) / (2 * sqrt(0 + (-255)(-255))) = -0.5 -> 120, and B > G -> 240.
  EXPECT_NEAR(*HsiHue(0, 0, 255), 240 * kDeg, 1e-9);
  // Yellow (255, 255, 0): (0 + 255) / (2 * sqrt(0 + 255*255)) = 0.5 -> 60 degrees.
  EXPECT_NEAR(*HsiHue(255, 255, 0), 60 * kDeg, 1e-9);
  // Magenta (255, 0, 255): B > G: (255 + 0) / (2 * sqrt(255^2 + 0)) = 0.5 -> 60 -> 360 - 60 = 300.
  EXPECT_NEAR(*HsiHue(255, 0, 255), 300 * kDeg, 1e-9);
}

TEST(HsiHueTest, MixedPixelByHand) {
  // (200, 100, 50): rg = 100, rb = 150, gb = 50. num = 250, den = 2*sqrt(10000 + 7500) = 264.575.
  const double expected = std::acos(250.0 / (2.0 * std::sqrt(17500.0)));
  EXPECT_NEAR(*HsiHue(200, 100, 50), expected, 1e-12);
  // Swapping G and B mirrors the hue: B > G gives 2*pi - H.
  EXPECT_NEAR(*HsiHue(200, 50, 100), 2 * M_PI - expected, 1e-12);
}

TEST(HsiHueTest, GrayHasNoHue) {
  EXPECT_FALSE(HsiHue(0, 0, 0).has_value());
  EXPECT_FALSE(HsiHue(128, 128, 128).has_value());
  EXPECT_FALSE(HsiHue(255, 255, 255).has_value());
  EXPECT_TRUE(HsiHue(128, 128, 129).has_value());
}

TEST(HueHistogramTest, BinsByHand) {
  EXPECT_EQ(HueBin(0.0, 36), 0);
  EXPECT_EQ(HueBin(*HsiHue(0, 0, 255), 36), 24);  // 240 degrees, on the boundary
  EXPECT_EQ(HueBin(2 * M_PI - 1e-6, 36), 35);
  EXPECT_EQ(HueBin(95 * kDeg, 36), 9);
}

TEST(HueHistogramTest, CountsColouredPixelsAndSkipsGray) {
  // 2x2 image (BGR): red, green, blue, gray.
  cv::Mat img(2, 2, CV_8UC3);
  img.at<cv::Vec3b>(0, 0) = {0, 0, 255};
  img.at<cv::Vec3b>(0, 1) = {0, 255, 0};
  img.at<cv::Vec3b>(1, 0) = {255, 0, 0};
  img.at<cv::Vec3b>(1, 1) = {90, 90, 90};
  const std::vector<float> h = HueHistogram(img, 36);
  ASSERT_EQ(h.size(), 36u);
  EXPECT_FLOAT_EQ(h[0], 1.0f / 3);   // red, 0 degrees
  EXPECT_FLOAT_EQ(h[12], 1.0f / 3);  // green, 120 degrees
  EXPECT_FLOAT_EQ(h[24], 1.0f / 3);  // blue, 240 degrees
  float sum = 0;
  for (float v : h) sum += v;
  EXPECT_NEAR(sum, 1.0, 1e-6);
}

TEST(HueHistogramTest, TableMatchesDirectFormulaOnEveryBin) {
  cv::Mat img(64, 64, CV_8UC3);
  cv::randu(img, 0, 256);
  const int bins = 36;
  std::vector<double> direct(bins, 0);
  double n = 0;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      auto h = HsiHue(p[2], p[1], p[0]);
      if (!h) continue;
      direct[HueBin(*h, bins)] += 1;
      n += 1;
    }
  }
  const std::vector<float> h = HueHistogram(img, bins);
  for (int i = 0; i < bins; ++i) EXPECT_NEAR(h[i], direct[i] / n, 1e-6) << "bin " << i;
}

TEST(HueHistogramTest, AllGrayImageGivesZeros) {
  cv::Mat img(8, 8, CV_8UC3, cv::Scalar(40, 40, 40));
  for (float v : HueHistogram(img, 32)) EXPECT_EQ(v, 0.0f);
}

TEST(BhattacharyyaTest, KnownHistograms) {
  EXPECT_NEAR(BhattacharyyaDistance({0.25f, 0.25f, 0.5f}, {0.25f, 0.25f, 0.5f}), 0.0, 1e-6);
  EXPECT_NEAR(BhattacharyyaDistance({1, 0}, {0, 1}), 1.0, 1e-9);
  // p = (0.5, 0.5), q = (1, 0): BC = sqrt(0.5) -> d = sqrt(1 - 0.70711) = 0.541196.
  EXPECT_NEAR(BhattacharyyaDistance({0.5f, 0.5f}, {1.0f, 0.0f}), 0.5411961, 1e-6);
  // p = (0.36, 0.64), q = (0.64, 0.36): BC = 0.48 + 0.48 = 0.96 -> d = 0.2.
  EXPECT_NEAR(BhattacharyyaDistance({0.36f, 0.64f}, {0.64f, 0.36f}), 0.2, 1e-6);
  EXPECT_NEAR(HueSimilarity({0.36f, 0.64f}, {0.64f, 0.36f}), 0.8, 1e-6);
}

TEST(BhattacharyyaTest, MismatchedOrEmptyHistogramsShareNothing) {
  EXPECT_EQ(BhattacharyyaDistance({0.5f, 0.5f}, {1.0f}), 1.0);
  EXPECT_EQ(BhattacharyyaDistance({0, 0}, {0.5f, 0.5f}), 1.0);
}

}  // namespace
}  // namespace waymark::crossing

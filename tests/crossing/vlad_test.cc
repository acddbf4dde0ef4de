// VLAD global descriptors (vlad.h): deterministic words, unit-norm codes, and the nearest code of
// a view seen again from a slightly different heading is its own.
#include "server/crossing/vlad.h"

#include <gtest/gtest.h>

#include "server/crossing/features.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::crossing {
namespace {

ImageFeatures Extract(const cv::Mat& image) {
  FeatureOptions options;
  options.root_sift = true;
  auto f = ExtractFeatures(testing::EncodePng(image), options);
  EXPECT_TRUE(f.ok()) << f.status();
  return *f;
}

TEST(VladTest, ViewsAreRetrievedByTheirGlobalCode) {
  std::vector<ImageFeatures> views;
  cv::Mat all;
  for (int place = 0; place < 4; ++place) {
    views.push_back(Extract(testing::CropView(testing::MakePanorama(300 + place), 0.0)));
    all.push_back(views.back().descriptors);
  }
  const VladVocabulary vocabulary = VladVocabulary::Train(all, 16);
  ASSERT_EQ(vocabulary.words(), 16);
  // Training is deterministic.
  const VladVocabulary again = VladVocabulary::Train(all, 16);
  EXPECT_EQ(cv::norm(vocabulary.Encode(views[0].descriptors), again.Encode(views[0].descriptors)),
            0.0);
  std::vector<cv::Mat> codes;
  for (const ImageFeatures& v : views) {
    codes.push_back(vocabulary.Encode(v.descriptors));
    EXPECT_NEAR(cv::norm(codes.back()), 1.0, 1e-5);
    EXPECT_EQ(codes.back().cols, 16 * 128);
  }
  // Each place seen 8 degrees further round is nearest to its own view.
  for (int place = 0; place < 4; ++place) {
    const cv::Mat q =
        vocabulary.Encode(Extract(testing::CropView(testing::MakePanorama(300 + place), 8.0))
                              .descriptors);
    int best = -1;
    double best_sim = -2;
    for (int i = 0; i < 4; ++i) {
      const double sim = q.dot(codes[i]);
      if (sim > best_sim) {
        best_sim = sim;
        best = i;
      }
    }
    EXPECT_EQ(best, place);
  }
}

TEST(VladTest, TooFewDescriptorsGiveAnEmptyVocabularyAndZeroCodes) {
  const cv::Mat few(3, 128, CV_8U, cv::Scalar(7));
  const VladVocabulary vocabulary = VladVocabulary::Train(few, 16);
  EXPECT_TRUE(vocabulary.empty());
  EXPECT_EQ(cv::countNonZero(vocabulary.Encode(few)), 0);
}

}  // namespace
}  // namespace waymark::crossing

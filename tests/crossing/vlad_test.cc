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

namespace waymark::crossing {
namespace {

// Issue 34: a user's bulk enrollment retrained at 44, 95, 228 and 301 views, because the worker
// learnt from every view present when it got to the database. The schedule learns from exactly
// the first 16, 32, 64, ... 512 views, whenever that is.
TEST(VocabularyScheduleTest, LearnsFromTheDocumentedSizesOnly) {
  EXPECT_EQ(VocabularyScheduleSize(0, 16, 512), 0);
  EXPECT_EQ(VocabularyScheduleSize(15, 16, 512), 0);
  EXPECT_EQ(VocabularyScheduleSize(16, 16, 512), 16);
  EXPECT_EQ(VocabularyScheduleSize(31, 16, 512), 16);
  EXPECT_EQ(VocabularyScheduleSize(44, 16, 512), 32);   // the user's first retraining
  EXPECT_EQ(VocabularyScheduleSize(95, 16, 512), 64);
  EXPECT_EQ(VocabularyScheduleSize(228, 16, 512), 128);
  EXPECT_EQ(VocabularyScheduleSize(301, 16, 512), 256);
  EXPECT_EQ(VocabularyScheduleSize(512, 16, 512), 512);
  EXPECT_EQ(VocabularyScheduleSize(12000, 16, 512), 512);  // then it stays
  // Every size the schedule gives is one of 16 * 2^k.
  for (int views = 16; views < 2000; ++views) {
    const int size = VocabularyScheduleSize(views, 16, 512);
    EXPECT_EQ(size & (size - 1), 0) << views;
    EXPECT_LE(size, views);
    EXPECT_GT(2 * size, std::min(views, 512 * 2 - 1)) << views;
  }
}

TEST(VocabularyScheduleTest, AVocabularyOfTheFirstViewsIgnoresTheViewsEnrolledSince) {
  std::vector<cv::Mat> samples;
  cv::RNG rng(7);
  for (int view = 0; view < 44; ++view) {
    cv::Mat rows(64, 128, CV_8U);
    rng.fill(rows, cv::RNG::UNIFORM, 0, view < 32 ? 128 : 256);  // later views differ
    samples.push_back(rows);
  }
  const int size = VocabularyScheduleSize(static_cast<int>(samples.size()), 16, 512);
  ASSERT_EQ(size, 32);
  const VladVocabulary scheduled = VladVocabulary::TrainOnFirstImages(samples, size, 16);
  const VladVocabulary first32 = VladVocabulary::TrainOnImages(
      std::vector<cv::Mat>(samples.begin(), samples.begin() + 32), 16);
  const VladVocabulary all44 = VladVocabulary::TrainOnImages(samples, 16);
  ASSERT_FALSE(scheduled.empty());
  EXPECT_EQ(scheduled.Fingerprint(), first32.Fingerprint());
  EXPECT_NE(scheduled.Fingerprint(), all44.Fingerprint());
  // Fewer views than asked for: all of them.
  EXPECT_EQ(VladVocabulary::TrainOnFirstImages(samples, 100, 16).Fingerprint(), all44.Fingerprint());
}

}  // namespace
}  // namespace waymark::crossing

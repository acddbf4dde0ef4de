// The retrieval mode's global stage: dense RootSIFT (dense_sift.h), the stored vocabulary
// (vlad.h) and the 8-bit scan (global_index.h) against the float vectors it stands for.
#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "server/crossing/dense_sift.h"
#include "server/crossing/enrollment.h"
#include "server/crossing/recognizer.h"
#include "server/crossing/features.h"
#include "server/crossing/global_index.h"
#include "server/crossing/view_database.h"
#include "server/crossing/vlad.h"
#include "tests/crossing/global_places.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::crossing {
namespace {

cv::Mat GreyView(int place, double heading = 0.0) {
  cv::Mat grey;
  cv::cvtColor(testing::CropView(testing::MakePanorama(300 + place), heading), grey,
               cv::COLOR_BGR2GRAY);
  return grey;
}

TEST(DenseSiftTest, OneDescriptorPerGridPointAndCellSize) {
  const cv::Mat grey = GreyView(0);
  DenseSiftOptions options;
  options.step = 8;
  options.cell_sizes = {4, 8};
  const cv::Mat d = DenseRootSift(grey, options);
  int expected = 0;
  for (int cell : options.cell_sizes) {
    const int span = 4 * cell;
    expected += ((grey.cols - span) / 8 + 1) * ((grey.rows - span) / 8 + 1);
  }
  EXPECT_EQ(d.rows, expected);
  EXPECT_EQ(d.cols, kDescriptorSize);
  EXPECT_EQ(d.type(), CV_8U);
  EXPECT_GT(cv::countNonZero(d), d.total() / 4) << "a textured view has gradients everywhere";
}

TEST(DenseSiftTest, DescriptorsMoveWithTheImage) {
  // Shifting the image left by one grid step shifts every descriptor one grid column left.
  const cv::Mat grey = GreyView(1);
  DenseSiftOptions options;
  options.step = 8;
  options.cell_sizes = {6};
  const cv::Mat shifted = grey.colRange(8, grey.cols).clone();
  const cv::Mat a = DenseRootSift(grey, options);
  const cv::Mat b = DenseRootSift(shifted, options);
  const int columns_a = (grey.cols - 24) / 8 + 1;
  const int columns_b = (shifted.cols - 24) / 8 + 1;
  ASSERT_EQ(columns_b, columns_a - 1);
  // Away from the image border, where the smoothing sees the same pixels in both.
  int compared = 0;
  for (int y = 2; y < a.rows / columns_a - 2; ++y) {
    for (int x = 3; x < columns_b - 2; ++x) {
      EXPECT_LE(cv::norm(a.row(y * columns_a + x + 1), b.row(y * columns_b + x), cv::NORM_INF), 1)
          << "grid point " << x << "," << y;
      ++compared;
    }
  }
  EXPECT_GT(compared, 50);
}

TEST(DenseSiftTest, TooSmallAnImageHasNoDescriptors) {
  EXPECT_TRUE(DenseRootSift(cv::Mat(10, 10, CV_8U, cv::Scalar(7))).empty());
}

TEST(VladVocabularyTest, SerializedVocabularyEncodesTheSame) {
  std::vector<cv::Mat> dense;
  for (int place = 0; place < 3; ++place) dense.push_back(DenseRootSift(GreyView(place)));
  const VladVocabulary vocabulary = VladVocabulary::TrainOnImages(dense, 32);
  ASSERT_EQ(vocabulary.words(), 32);
  absl::StatusOr<VladVocabulary> back = VladVocabulary::Deserialize(vocabulary.Serialize());
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(cv::norm(vocabulary.Encode(dense[1]), back->Encode(dense[1]), cv::NORM_INF), 0.0);
}

TEST(VladVocabularyTest, CorruptBytesAreRefused) {
  std::vector<cv::Mat> dense = {DenseRootSift(GreyView(0))};
  const std::string bytes = VladVocabulary::TrainOnImages(dense, 8).Serialize();
  EXPECT_EQ(VladVocabulary::Deserialize("").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(VladVocabulary::Deserialize(bytes.substr(0, bytes.size() - 3)).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::string wrong_magic = bytes;
  wrong_magic[0] = 'X';
  EXPECT_EQ(VladVocabulary::Deserialize(wrong_magic).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::string wrong_format = bytes;
  wrong_format[4] = 9;
  EXPECT_EQ(VladVocabulary::Deserialize(wrong_format).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(GlobalIndexTest, QuantisedScanRanksAsTheFloatVectors) {
  // 12 places x 3 headings; each view's query is the same place 6 degrees on.
  std::vector<cv::Mat> dense;
  for (int place = 0; place < 12; ++place) {
    for (double heading : {0.0, 30.0, 60.0}) dense.push_back(DenseRootSift(GreyView(place, heading)));
  }
  const VladVocabulary vocabulary = VladVocabulary::TrainOnImages(dense, 32);
  GlobalIndex index;
  index.Reset(vocabulary.words() * kDescriptorSize);
  std::vector<cv::Mat> floats;
  for (uint32_t slot = 0; slot < dense.size(); ++slot) {
    floats.push_back(vocabulary.Encode(dense[slot]));
    index.Set(slot, QuantizeGlobal(floats.back()));
  }
  int same_top1 = 0, own_place = 0;
  double overlap = 0;
  for (size_t v = 0; v < dense.size(); ++v) {
    const int place = static_cast<int>(v / 3);
    const double heading = 30.0 * (v % 3) + 6.0;
    const cv::Mat query = vocabulary.Encode(DenseRootSift(GreyView(place, heading)));
    std::vector<float> exact;
    for (const cv::Mat& f : floats) exact.push_back(static_cast<float>(query.dot(f)));
    const std::vector<float> quantised = index.Similarities(QuantizeGlobal(query));
    for (size_t i = 0; i < exact.size(); ++i) EXPECT_NEAR(quantised[i], exact[i], 0.01);
    const auto top_exact = TopSimilar(exact, 5);
    const auto top_quantised = TopSimilar(quantised, 5);
    same_top1 += top_exact[0].second == top_quantised[0].second;
    own_place += static_cast<int>(top_quantised[0].second / 3) == place;
    for (const auto& [s, slot] : top_quantised) {
      overlap += std::any_of(top_exact.begin(), top_exact.end(),
                             [&](const auto& e) { return e.second == slot; });
    }
  }
  EXPECT_EQ(same_top1, static_cast<int>(dense.size()));
  EXPECT_GE(overlap / (5.0 * dense.size()), 0.95);
  EXPECT_GE(own_place, static_cast<int>(dense.size()) - 2);
}

TEST(GlobalIndexTest, SlotsWithoutACodeScoreZero) {
  GlobalIndex index;
  index.Reset(4);
  cv::Mat v = (cv::Mat_<float>(1, 4) << 0.5f, 0.5f, 0.5f, 0.5f);
  index.Set(2, QuantizeGlobal(v));
  index.Set(3, GlobalCode{{1, 2}, 1.f});  // wrong length: ignored
  const std::vector<float> s = index.Similarities(QuantizeGlobal(v));
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0], 0.f);
  EXPECT_EQ(s[1], 0.f);
  EXPECT_NEAR(s[2], 1.f, 1e-6);
  EXPECT_EQ(s[3], 0.f);
}

TEST(GlobalIndexTest, ANewVocabularyDropsTheOldCodes) {
  ViewDatabase db;
  std::vector<cv::Mat> dense;
  for (int place = 0; place < 2; ++place) {
    const cv::Mat grey = GreyView(place);
    dense.push_back(DenseRootSift(grey));
    db.AddView(place + 1, place + 1, 0.0, cv::Mat(0, 128, CV_8U), {}, {});
  }
  db.TrainGlobal(dense, 16);
  EXPECT_EQ(db.global_index().dims(), 16 * 128);
  EXPECT_GT(db.global_index().Similarities(QuantizeGlobal(db.vocabulary().Encode(dense[0])))[0],
            0.99f);
  db.SetVocabulary(VladVocabulary::TrainOnImages(dense, 8));
  EXPECT_EQ(db.global_index().dims(), 8 * 128);
  EXPECT_EQ(db.global_index().size(), 0u);
}

TEST(GlobalIndexTest, StoredCodesComeBackWithTheirVocabulary) {
  const StoredGlobalCode stored{0x0123456789abcdefull, GlobalCode{{-127, 0, 5, 127}, 0.25f}};
  absl::StatusOr<StoredGlobalCode> back = DeserializeGlobalCode(SerializeGlobalCode(stored));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->vocabulary, stored.vocabulary);
  EXPECT_EQ(back->code.values, stored.code.values);
  EXPECT_EQ(back->code.scale, stored.code.scale);

  const std::string bytes = SerializeGlobalCode(stored);
  EXPECT_EQ(DeserializeGlobalCode("").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(DeserializeGlobalCode(bytes.substr(0, bytes.size() - 1)).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::string wrong_magic = bytes;
  wrong_magic[1] = 'x';
  EXPECT_EQ(DeserializeGlobalCode(wrong_magic).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(GlobalIndexTest, GetReturnsWhatWasSetAndCodedCountsIt) {
  GlobalIndex index;
  index.Reset(3);
  index.Set(1, GlobalCode{{1, -2, 3}, 0.5f});
  EXPECT_EQ(index.coded(), 1u);
  EXPECT_EQ(index.Get(1).values, (std::vector<int8_t>{1, -2, 3}));
  EXPECT_EQ(index.Get(1).scale, 0.5f);
  EXPECT_TRUE(index.Get(0).values.empty());   // never set
  EXPECT_TRUE(index.Get(7).values.empty());   // beyond the index
}

TEST(VladVocabularyTest, EvenRowsSpreadOverTheWholeMatrix) {
  cv::Mat rows(100, 2, CV_8U);
  for (int r = 0; r < rows.rows; ++r) rows.at<uint8_t>(r, 0) = static_cast<uint8_t>(r);
  const cv::Mat four = EvenRows(rows, 4);
  ASSERT_EQ(four.rows, 4);
  EXPECT_EQ(four.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(four.at<uint8_t>(3, 0), 75);
  EXPECT_EQ(EvenRows(rows, 200).rows, 100);
  EXPECT_EQ(EvenRows(rows, 0).rows, 0);
}

TEST(VladVocabularyTest, TheFingerprintNamesTheWords) {
  std::vector<cv::Mat> dense = {DenseRootSift(GreyView(0)), DenseRootSift(GreyView(1))};
  const VladVocabulary a = VladVocabulary::TrainOnImages(dense, 16);
  const VladVocabulary b = VladVocabulary::TrainOnImages(dense, 8);
  EXPECT_NE(a.Fingerprint(), 0u);
  EXPECT_NE(a.Fingerprint(), b.Fingerprint());
  EXPECT_EQ(VladVocabulary::Deserialize(a.Serialize())->Fingerprint(), a.Fingerprint());
  EXPECT_EQ(VladVocabulary().Fingerprint(), 0u);
}

// The retrieval mode's global path (RecognitionOptions::min_global_lift): with the NFA path shut,
// a query of an enrolled place is accepted on how far its most similar view stands out, a query
// of a place not enrolled is not, and the threshold decides.
TEST(GlobalPathTest, TheMostSimilarViewIsTheAnswerWhenItStandsOutEnough) {
  ViewDatabase db;
  testing_places::EnrollSixPlaces(500, &db);

  RecognitionOptions options;
  options.mode = RecognitionMode::kRetrieval;
  options.max_log10_nfa = -10000;  // only the global path can accept
  options.min_global_lift = 0;
  options.max_log10_global_efa = -10000;  // the chance model's rule shut too: the legacy lift
  const ImageFeatures known = testing_places::GlobalView(502, 100.0);
  const ImageFeatures unknown = testing_places::GlobalView(599, 100.0);
  auto known_off = Recognize(db, known, options);
  auto unknown_off = Recognize(db, unknown, options);
  ASSERT_TRUE(known_off.ok() && unknown_off.ok());
  EXPECT_FALSE(known_off->recognized);  // 0 = off: nothing accepts
  EXPECT_GT(known_off->global_lift, unknown_off->global_lift + 0.02);

  options.min_global_lift = (known_off->global_lift + unknown_off->global_lift) / 2;
  auto accepted = Recognize(db, known, options);
  ASSERT_TRUE(accepted.ok());
  ASSERT_TRUE(accepted->recognized) << accepted->reason;
  EXPECT_TRUE(accepted->accepted_by_global);
  EXPECT_EQ(db.views()[accepted->best_slot].crossing_id, 3);
  auto refused = Recognize(db, unknown, options);
  ASSERT_TRUE(refused.ok());
  EXPECT_FALSE(refused->recognized);
  EXPECT_FALSE(refused->accepted_by_global);
  EXPECT_NE(refused->reason.find("above the median global similarity"), std::string::npos)
      << refused->reason;
}

}  // namespace
}  // namespace waymark::crossing

#include "server/crossing/recognizer.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/decision.h"
#include "server/crossing/view_database.h"
#include "server/crossing/view_matching.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::crossing {
namespace {

// Three generated crossings, 12 views each at 30-degree steps, clustered as the paper does.
class RecognizerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    db_ = new ViewDatabase();
    for (int crossing = 0; crossing < 3; ++crossing) {
      panoramas_[crossing] = testing::MakePanorama(100 + crossing);
      for (int k = 0; k < 12; ++k) {
        const ImageFeatures f = Extract(testing::CropView(panoramas_[crossing], 30.0 * k));
        EnrollView(db_, 1 + crossing * 12 + k, crossing + 1, 30.0 * k, f);
      }
    }
  }
  static void TearDownTestSuite() { delete db_; }

  static ImageFeatures Extract(const cv::Mat& image) {
    FeatureOptions options;
    auto f = ExtractFeatures(testing::EncodePng(image), options);
    EXPECT_TRUE(f.ok()) << f.status();
    return *f;
  }

  static ViewDatabase* db_;
  static cv::Mat panoramas_[3];
};
ViewDatabase* RecognizerTest::db_ = nullptr;
cv::Mat RecognizerTest::panoramas_[3];

TEST_F(RecognizerTest, ClustersAreFewerThanViewsAndCoverEveryView) {
  EXPECT_GT(db_->clusters().size(), 2u);
  EXPECT_LT(db_->clusters().size(), 36u);
  size_t members = 0;
  for (const auto& c : db_->clusters()) {
    EXPECT_EQ(c.members.front(), c.center);
    members += c.members.size();
  }
  EXPECT_EQ(members, 36u);
  for (const auto& v : db_->views()) EXPECT_GE(v.cluster, 0);
}

TEST_F(RecognizerTest, ClusteringFollowsEnrollmentOrder) {
  // View 1 is always the first centre, and recomputing from scratch gives the same clusters as
  // the incremental assignment above.
  EXPECT_EQ(db_->clusters().front().center, 0u);
  const auto recomputed = db_->ComputeClusters(ClusterOptions{});
  ASSERT_EQ(recomputed.size(), db_->clusters().size());
  for (size_t c = 0; c < recomputed.size(); ++c) {
    EXPECT_EQ(recomputed[c].members, db_->clusters()[c].members);
  }
}

TEST_F(RecognizerTest, HigherThresholdMakesMoreClusters) {
  ClusterOptions strict;
  strict.threshold = 1000;  // nothing joins: every view is its own centre
  EXPECT_EQ(db_->ComputeClusters(strict).size(), 36u);
}

TEST_F(RecognizerTest, RecognizesStoredHeadingsInPaperMode) {
  for (int crossing = 0; crossing < 3; ++crossing) {
    for (int k = 0; k < 12; k += 5) {
      const auto result =
          Recognize(*db_, Extract(testing::CropView(panoramas_[crossing], 30.0 * k)), {});
      ASSERT_TRUE(result.ok()) << result.status();
      ASSERT_TRUE(result->recognized) << result->reason;
      const ViewEntry& best = db_->views()[result->best_slot];
      EXPECT_EQ(best.crossing_id, crossing + 1);
      EXPECT_DOUBLE_EQ(best.heading_deg, 30.0 * k);
      EXPECT_GT(result->qualifying_clusters, 0);
      EXPECT_FALSE(result->candidates.empty());
    }
  }
}

TEST_F(RecognizerTest, RecognizesTwelveDegreesOffTheStoredHeading) {
  const auto result = Recognize(*db_, Extract(testing::CropView(panoramas_[1], 72.0)), {});
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(result->recognized) << result->reason;
  const ViewEntry& best = db_->views()[result->best_slot];
  EXPECT_EQ(best.crossing_id, 2);
  // One of the two stored headings either side (60 or 90): the estimate is the best view's.
  EXPECT_TRUE(best.heading_deg == 60.0 || best.heading_deg == 90.0) << best.heading_deg;
}

TEST_F(RecognizerTest, CandidateTableIsSortedAndKeepsN2) {
  const auto result = Recognize(*db_, Extract(testing::CropView(panoramas_[0], 45.0)), {});
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(result->recognized);
  int kept = 0;
  for (size_t i = 0; i < result->candidates.size(); ++i) {
    const Candidate& c = result->candidates[i];
    if (i > 0) {
      EXPECT_LE(c.matches, result->candidates[i - 1].matches);
    }
    if (c.kept) {
      ++kept;
      EXPECT_GT(c.decision, 0);
      EXPECT_LE(c.decision, 1.0 + 1e-9);
    }
  }
  EXPECT_EQ(kept, std::min<int>(3, result->candidates.size()));
  EXPECT_NEAR(result->decision, 1.0, 0.5);
}

TEST_F(RecognizerTest, UnknownPlaceIsNotRecognized) {
  const cv::Mat other = testing::MakePanorama(999);
  for (RecognitionMode mode :
       {RecognitionMode::kPaper, RecognitionMode::kVerified, RecognitionMode::kRetrieval}) {
    RecognitionOptions options;
    options.mode = mode;
    const auto result = Recognize(*db_, Extract(testing::CropView(other, 100)), options);
    ASSERT_TRUE(result.ok());
    EXPECT_FALSE(result->recognized) << "mode " << static_cast<int>(mode) << " nfa " << result->log10_nfa << " inl " << (result->candidates.empty() ? -1 : result->candidates.front().matches) << "/" << (result->candidates.empty() ? -1 : result->candidates.front().tentative);
    EXPECT_FALSE(result->reason.empty());
  }
}

TEST_F(RecognizerTest, VerifiedModeRecognizesWithInliers) {
  RecognitionOptions options;
  options.mode = RecognitionMode::kVerified;
  const auto result = Recognize(*db_, Extract(testing::CropView(panoramas_[2], 200.0)), options);
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(result->recognized) << result->reason;
  EXPECT_EQ(db_->views()[result->best_slot].crossing_id, 3);
  EXPECT_GE(result->candidates.front().matches, options.min_inliers);
  EXPECT_LE(result->candidates.front().matches, result->candidates.front().tentative);
}

TEST_F(RecognizerTest, RetrievalModeAcceptsByFalseAlarmsAndSaysHowSure) {
  RecognitionOptions options;
  options.mode = RecognitionMode::kRetrieval;
  const auto result = Recognize(*db_, Extract(testing::CropView(panoramas_[1], 110.0)), options);
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(result->recognized) << result->reason;
  EXPECT_EQ(db_->views()[result->best_slot].crossing_id, 2);
  EXPECT_LT(result->log10_nfa, options.max_log10_nfa);
  // The answer says why: the NFA path, with its NFA computed.
  EXPECT_EQ(result->accepted_by, AcceptedBy::kNfa);
  EXPECT_STREQ(AcceptedByName(result->accepted_by), "nfa");
  EXPECT_TRUE(result->nfa_computed);
  // Candidates are ordered by their evidence, and every one carries it.
  for (size_t i = 1; i < result->candidates.size(); ++i) {
    EXPECT_LE(result->candidates[i - 1].log10_nfa, result->candidates[i].log10_nfa);
  }
  // The same frame with the limit at its own evidence is refused, with the reason.
  options.max_log10_nfa = result->log10_nfa;
  const auto strict = Recognize(*db_, Extract(testing::CropView(panoramas_[1], 110.0)), options);
  ASSERT_TRUE(strict.ok());
  EXPECT_FALSE(strict->recognized);
  EXPECT_NE(strict->reason.find("could be chance"), std::string::npos) << strict->reason;
}

TEST_F(RecognizerTest, TexturelessImageIsANormalNegativeAnswer) {
  const cv::Mat flat(240, 320, CV_8UC3, cv::Scalar(30, 120, 200));
  const auto result = Recognize(*db_, Extract(flat), {});
  ASSERT_TRUE(result.ok());
  EXPECT_FALSE(result->recognized);
  EXPECT_NE(result->reason.find("no SIFT keypoints"), std::string::npos);
}

TEST_F(RecognizerTest, BadOptionsAreInvalidArgument) {
  const ImageFeatures f = Extract(testing::CropView(panoramas_[0], 0));
  RecognitionOptions options;
  options.ratio = 1.5;
  EXPECT_EQ(Recognize(*db_, f, options).status().code(), absl::StatusCode::kInvalidArgument);
  options = {};
  options.alpha = 0.7;  // alpha + beta != 1
  EXPECT_EQ(Recognize(*db_, f, options).status().code(), absl::StatusCode::kInvalidArgument);
}

// Clustering through the index (incremental or rebuilt from scratch) must make the same clusters
// as the paper's quadratic procedure with exact matching against every centre.
TEST(ClusteringTest, IndexedClusteringEqualsExactQuadraticClustering) {
  ViewDatabase db;
  int incremental = 0;
  for (int crossing = 0; crossing < 12; ++crossing) {
    const cv::Mat pano = testing::MakePanorama(300 + crossing);
    for (int k = 0; k < 12; ++k) {
      auto f = ExtractFeatures(testing::EncodePng(testing::CropView(pano, 30.0 * k + 7 * crossing)),
                               FeatureOptions{});
      ASSERT_TRUE(f.ok());
      incremental += EnrollView(&db, crossing * 12 + k + 1, crossing + 1, 30.0 * k, *f).new_cluster;
    }
  }
  std::vector<uint32_t> centres;
  for (const ClusterEntry& c : QuadraticClusters(db, ClusterOptions{})) centres.push_back(c.center);
  const auto rebuilt = db.ComputeClusters(ClusterOptions{});
  std::vector<uint32_t> rebuilt_centres;
  for (const auto& c : rebuilt) rebuilt_centres.push_back(c.center);
  EXPECT_EQ(rebuilt_centres, centres);
  EXPECT_EQ(incremental, static_cast<int>(centres.size()));
}

TEST(RecognizerEmptyTest, EmptyDatabaseIsFailedPrecondition) {
  ViewDatabase empty;
  ImageFeatures f;
  EXPECT_EQ(Recognize(empty, f, {}).status().code(), absl::StatusCode::kFailedPrecondition);
}

// Issue 21: a PNG's header may claim any size, and a decoder allocates what it claims (a 1 MB PNG
// of 20000 x 20000 zeros took the server to 1.2 GB before its size check). The size is refused on
// the header, before decoding: this one's pixel data is not even there, so a decoder would have
// failed with another message.
TEST(FeaturesTest, AnImageClaimingTooManyPixelsIsRefusedOnItsHeaderBeforeDecoding) {
  std::string png = testing::EncodePng(testing::MakePanorama(1, 64, 48));
  const unsigned char claimed[8] = {0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30};  // 30000 x 30000
  png.replace(16, 8, reinterpret_cast<const char*>(claimed), 8);
  const absl::Status refused = ExtractFeatures(png, FeatureOptions()).status();
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.message().find("30000x30000: more than 64 megapixels"), std::string::npos)
      << refused;
  const absl::Status headless = ExtractFeatures(std::string(200, 'x') + "IEND", {}).status();
  EXPECT_NE(headless.message().find("not a JPEG or PNG image"), std::string::npos) << headless;
}

TEST(FeaturesTest, CorruptAndTinyImagesAreInvalidArgument) {
  FeatureOptions options;
  EXPECT_EQ(ExtractFeatures("", options).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ExtractFeatures("not an image at all", options).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::string truncated = testing::EncodeJpeg(testing::MakePanorama(1, 320, 240));
  truncated.resize(40);
  EXPECT_EQ(ExtractFeatures(truncated, options).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::string cut_png = testing::EncodePng(testing::MakePanorama(1, 320, 240));
  cut_png.resize(cut_png.size() / 2);
  EXPECT_EQ(ExtractFeatures(cut_png, options).status().code(), absl::StatusCode::kInvalidArgument);
  std::string cut_jpeg = testing::EncodeJpeg(testing::MakePanorama(1, 320, 240));
  cut_jpeg.resize(cut_jpeg.size() * 2 / 3);  // libjpeg would decode this with gray fill
  EXPECT_EQ(ExtractFeatures(cut_jpeg, options).status().code(), absl::StatusCode::kInvalidArgument);
  const cv::Mat one(1, 1, CV_8UC3, cv::Scalar(1, 2, 3));
  EXPECT_EQ(ExtractFeatures(testing::EncodePng(one), options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(FeaturesTest, AnySizeIsResizedToWorkingResolution) {
  FeatureOptions options;
  const cv::Mat big = testing::MakePanorama(7, 1280, 960);
  auto f = ExtractFeatures(testing::EncodeJpeg(big), options);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->width, 320);
  EXPECT_EQ(f->height, 240);
  EXPECT_GT(f->descriptors.rows, 50);
  EXPECT_EQ(f->descriptors.type(), CV_8U);
  for (const auto& kp : f->keypoints) {
    EXPECT_LT(kp.pt.x, 320);
    EXPECT_LT(kp.pt.y, 240);
  }
}

TEST(FeaturesTest, KeepAspectFitsTheImageIntoTheWorkingSize) {
  FeatureOptions options;
  options.keep_aspect = true;
  EXPECT_EQ(WorkingSize(cv::Size(1280, 960), options), cv::Size(320, 240));
  EXPECT_EQ(WorkingSize(cv::Size(1241, 376), options), cv::Size(320, 97));   // KITTI
  EXPECT_EQ(WorkingSize(cv::Size(3024, 4032), options), cv::Size(180, 240));  // a portrait photo
  options.keep_aspect = false;  // the paper's plain resize
  EXPECT_EQ(WorkingSize(cv::Size(1241, 376), options), cv::Size(320, 240));

  options.keep_aspect = true;
  const cv::Mat wide = testing::MakePanorama(5, 1200, 400);
  auto f = ExtractFeatures(testing::EncodePng(wide), options);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->width, 320);
  EXPECT_EQ(f->height, 107);
}

TEST(FeaturesTest, RootSiftDescriptorsHaveUnitLengthBeforeQuantisation) {
  FeatureOptions options;
  options.root_sift = true;
  auto f = ExtractFeatures(testing::EncodePng(testing::MakePanorama(9, 640, 480)), options);
  ASSERT_TRUE(f.ok());
  ASSERT_GT(f->descriptors.rows, 20);
  for (int r = 0; r < f->descriptors.rows; ++r) {
    const double norm = cv::norm(f->descriptors.row(r), cv::NORM_L2) / 512.0;
    EXPECT_NEAR(norm, 1.0, 0.05) << "row " << r;
  }
  // The same keypoints as plain SIFT: only the descriptors change.
  options.root_sift = false;
  auto plain = ExtractFeatures(testing::EncodePng(testing::MakePanorama(9, 640, 480)), options);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->keypoints.size(), f->keypoints.size());
}

}  // namespace
}  // namespace waymark::crossing

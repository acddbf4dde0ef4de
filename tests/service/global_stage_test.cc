// The retrieval mode's global stage in the registry (global_stage.h), on a real SQLite file without
// gRPC: a vocabulary learnt at 16 views and again when they double, every view coded, the codes
// kept through deleting and replacing views, and the same answers after a restart.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/crossing_registry.h"
#include "storage/crossing_store.h"
#include "tests/service/registry_on_file.h"
#include "tests/storage/temp_dir.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::service {
namespace {

using storage::testing::TempDir;

constexpr int kPlaces = 8;

class GlobalStageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.File("waymark.db");
    Load();
    for (int p = 0; p < kPlaces; ++p) panoramas_.push_back(testing::MakePanorama(40 + p));
  }

  void Load() {
    registry_.reset();  // one registry per file at a time, as one server
    registry_ = testing::LoadRegistry(path_);
    ASSERT_NE(registry_, nullptr);
  }

  void Create(v1::RecognitionMode mode) {
    v1::CreateDatabaseRequest create;
    create.set_name("campus");
    create.mutable_params()->mutable_recognition()->set_mode(mode);
    absl::StatusOr<v1::CrossingDatabase> db = registry_->CreateDatabase(create);
    ASSERT_TRUE(db.ok()) << db.status();
    EXPECT_EQ(db->params().global_descriptor(), mode == v1::RECOGNITION_MODE_RETRIEVAL);
  }

  static std::string Name(int place) { return "P" + std::to_string(place); }

  // View `n` of the database: places in turn, headings 45 degrees apart.
  v1::EnrollViewRequest View(int n) const {
    v1::EnrollViewRequest request;
    request.set_database("campus");
    request.set_crossing(Name(n % kPlaces));
    request.set_heading_deg(45.0 * (n / kPlaces));
    request.set_create_crossing(true);
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(panoramas_[n % kPlaces], 45.0 * (n / kPlaces))));
    return request;
  }

  void EnrollViews(int from, int to) {
    for (int n = from; n < to; ++n) {
      absl::StatusOr<v1::EnrollViewResponse> answer = registry_->EnrollView(View(n));
      ASSERT_TRUE(answer.ok()) << answer.status();
      ASSERT_EQ(answer->outcome(), v1::ENROLL_OUTCOME_STORED);
    }
  }

  // After the worker is done: how many views the vocabulary was learnt from, and are coded.
  std::pair<int, int> SettledStage() {
    registry_->WaitForGlobalStage();
    const v1::DatabaseStats stats = Stats();
    return {stats.vocabulary_views(), stats.coded_views()};
  }

  v1::DatabaseStats Stats() {
    absl::StatusOr<v1::DatabaseStats> stats = registry_->GetStats("campus");
    EXPECT_TRUE(stats.ok()) << stats.status();
    return stats.ok() ? *stats : v1::DatabaseStats();
  }

  // A query between two enrolled headings of `place`.
  v1::RecognizeResponse Recognize(int place, double heading) {
    v1::RecognizeRequest request;
    request.set_database("campus");
    request.mutable_params()->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(panoramas_[place], heading)));
    absl::StatusOr<v1::RecognizeResponse> answer = registry_->Recognize(request);
    EXPECT_TRUE(answer.ok()) << answer.status();
    return answer.ok() ? *answer : v1::RecognizeResponse();
  }

  static double BestGlobalSimilarity(const v1::RecognizeResponse& response) {
    double best = 0;
    for (const v1::Candidate& c : response.candidates()) best = std::max(best, c.global_similarity());
    return best;
  }

  TempDir dir_;
  std::string path_;
  std::unique_ptr<CrossingRegistry> registry_;
  std::vector<cv::Mat> panoramas_;
};

TEST(GlobalStageScheduleTest, AVocabularyIsDueAtSixteenViewsAndAtEachDoublingUpTo512) {
  EXPECT_FALSE(NeedsVocabulary(15, 0));
  EXPECT_TRUE(NeedsVocabulary(16, 0));
  EXPECT_FALSE(NeedsVocabulary(31, 20));  // learnt from 20: counts for 16
  EXPECT_TRUE(NeedsVocabulary(32, 20));
  EXPECT_FALSE(NeedsVocabulary(63, 32));
  EXPECT_TRUE(NeedsVocabulary(1000, 300));  // 512 is due
  EXPECT_FALSE(NeedsVocabulary(5000, 512));  // and the last
}

TEST_F(GlobalStageTest, AVocabularyIsLearntAtSixteenViewsAndEveryLaterViewIsCodedAtOnce) {
  Create(v1::RECOGNITION_MODE_RETRIEVAL);
  EnrollViews(0, 15);
  EXPECT_EQ(SettledStage(), std::make_pair(0, 0));
  EXPECT_EQ(BestGlobalSimilarity(Recognize(2, 10)), 0.0);  // no global stage yet

  EnrollViews(15, 16);
  EXPECT_EQ(SettledStage(), std::make_pair(16, 16));
  // The worker is idle: a new view is coded by its own enrollment.
  EnrollViews(16, 17);
  EXPECT_EQ(Stats().coded_views(), 17);

  const v1::RecognizeResponse answer = Recognize(2, 10);
  EXPECT_TRUE(answer.recognized());
  EXPECT_EQ(answer.crossing(), Name(2));
  EXPECT_GT(BestGlobalSimilarity(answer), 0.5);
  EXPECT_GT(answer.timings().retrieval_ms(), 0.0);
}

TEST_F(GlobalStageTest, TheVocabularyIsLearntAgainWhenTheViewsDoubleAndSurvivesARestart) {
  Create(v1::RECOGNITION_MODE_RETRIEVAL);
  EnrollViews(0, 32);
  EXPECT_EQ(SettledStage(), std::make_pair(32, 32));
  const v1::RecognizeResponse before = Recognize(5, 100);

  Load();
  EXPECT_EQ(SettledStage(), std::make_pair(32, 32));
  const v1::RecognizeResponse after = Recognize(5, 100);
  EXPECT_EQ(after.recognized(), before.recognized());
  EXPECT_EQ(after.crossing(), before.crossing());
  EXPECT_EQ(after.view_id(), before.view_id());
  EXPECT_EQ(after.log10_nfa(), before.log10_nfa());
  ASSERT_EQ(after.candidates_size(), before.candidates_size());
  for (int i = 0; i < after.candidates_size(); ++i) {
    EXPECT_EQ(after.candidates(i).view_id(), before.candidates(i).view_id());
    EXPECT_EQ(after.candidates(i).global_similarity(), before.candidates(i).global_similarity());
  }
  EXPECT_GT(BestGlobalSimilarity(after), 0.5);
}

TEST_F(GlobalStageTest, DeletingAndReplacingViewsKeepTheOthersCodes) {
  Create(v1::RECOGNITION_MODE_RETRIEVAL);
  EnrollViews(0, 24);
  registry_->WaitForGlobalStage();
  // Learnt once the 16th view was in, from as many as the worker saw when it looked.
  ASSERT_GE(Stats().vocabulary_views(), 16);
  ASSERT_LE(Stats().vocabulary_views(), 24);
  ASSERT_EQ(Stats().coded_views(), 24);

  v1::DeleteCrossingRequest erase;
  erase.set_database("campus");
  erase.set_name(Name(7));
  ASSERT_TRUE(registry_->DeleteCrossing(erase).ok());
  EXPECT_EQ(Stats().database().views(), 21);
  EXPECT_EQ(Stats().coded_views(), 21);

  // View 9 again at its own place, from another image: it replaces the stored one.
  v1::EnrollViewRequest replacement = View(9);
  replacement.mutable_image()->set_data(
      testing::EncodePng(testing::CropView(panoramas_[1], 47.0)));
  replacement.set_replace(true);
  absl::StatusOr<v1::EnrollViewResponse> replaced = registry_->EnrollView(replacement);
  ASSERT_TRUE(replaced.ok()) << replaced.status();
  EXPECT_EQ(replaced->replaced_view_ids_size(), 1);
  EXPECT_EQ(Stats().database().views(), 21);
  EXPECT_EQ(Stats().coded_views(), 21);
  EXPECT_EQ(Recognize(1, 50).crossing(), Name(1));
}

TEST_F(GlobalStageTest, ADatabaseWithoutTheGlobalDescriptorLearnsNothing) {
  Create(v1::RECOGNITION_MODE_PAPER);
  EnrollViews(0, 16);
  EXPECT_EQ(SettledStage(), std::make_pair(0, 0));
  EXPECT_FALSE(Stats().database().params().global_descriptor());
}

}  // namespace
}  // namespace waymark::service

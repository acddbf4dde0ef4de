// CrossingRegistry::EnrollView on a real SQLite file, without gRPC: duplicates by image hash,
// `replace`, a database written before hashes were stored (schema v4), whose views have none, and
// capture positions (issue 18).

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/crossing/crossing_registry.h"
#include "storage/crossing_store.h"
#include "storage/sqlite.h"
#include "tests/service/registry_on_file.h"
#include "tests/storage/temp_dir.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::service {
namespace {

using storage::testing::TempDir;

class CrossingEnrollmentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.File("waymark.db");
    Load();
    v1::CreateDatabaseRequest create;
    create.set_name("campus");
    ASSERT_TRUE(registry_->CreateDatabase(create).ok());
    panorama_ = testing::MakePanorama(31);
  }

  void Load() {
    registry_.reset();  // one registry per file at a time, as one server
    registry_ = testing::LoadRegistry(path_);
    ASSERT_NE(registry_, nullptr);
  }

  v1::EnrollViewRequest View(const std::string& crossing, double heading, double taken_at) const {
    v1::EnrollViewRequest request;
    request.set_database("campus");
    request.set_crossing(crossing);
    request.set_heading_deg(heading);
    request.set_create_crossing(true);
    request.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama_, taken_at)));
    return request;
  }

  v1::EnrollViewResponse Enroll(const v1::EnrollViewRequest& request) {
    absl::StatusOr<v1::EnrollViewResponse> answer = registry_->EnrollView(request);
    EXPECT_TRUE(answer.ok()) << answer.status();
    return answer.ok() ? *answer : v1::EnrollViewResponse();
  }

  int Views() {
    absl::StatusOr<v1::DatabaseStats> stats = registry_->GetStats("campus");
    EXPECT_TRUE(stats.ok()) << stats.status();
    return stats.ok() ? stats->database().views() : -1;
  }

  TempDir dir_;
  std::string path_;
  std::unique_ptr<CrossingRegistry> registry_;
  cv::Mat panorama_;
};

TEST_F(CrossingEnrollmentTest, TheSameImageIsADuplicateNamingTheStoredView) {
  const v1::EnrollViewResponse first = Enroll(View("A", 0, 0));
  EXPECT_EQ(first.outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_TRUE(first.crossing_created());
  const v1::EnrollViewResponse again = Enroll(View("A", 0, 0));
  EXPECT_EQ(again.outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(again.view_id(), first.view_id());
  EXPECT_EQ(again.crossing(), "A");
  EXPECT_FALSE(again.crossing_created());
  // Under another crossing and heading: still the same image; no crossing is created for it.
  const v1::EnrollViewResponse elsewhere = Enroll(View("B", 90, 0));
  EXPECT_EQ(elsewhere.outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(elsewhere.view_id(), first.view_id());
  EXPECT_EQ(Views(), 1);
  EXPECT_EQ(registry_->ListCrossings("campus")->crossings_size(), 1);
}

// A request naming a crossing that does not exist (without create_crossing) is refused as such,
// even when its image is stored: the request is wrong whatever the image.
TEST_F(CrossingEnrollmentTest, AnUnknownCrossingIsNotFoundBeforeTheImageIsADuplicate) {
  Enroll(View("A", 0, 0));
  v1::EnrollViewRequest request = View("nowhere", 0, 0);
  request.set_create_crossing(false);
  EXPECT_EQ(registry_->EnrollView(request).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(CrossingEnrollmentTest, ReplaceTakesThePlaceOfTheViewAtTheSameCrossingAndHeading) {
  const v1::EnrollViewResponse old = Enroll(View("A", 0, 0));
  Enroll(View("A", 90, 90));
  v1::EnrollViewRequest reshot = View("A", 0, 5);
  reshot.set_replace(true);
  const v1::EnrollViewResponse replaced = Enroll(reshot);
  EXPECT_EQ(replaced.outcome(), v1::ENROLL_OUTCOME_STORED);
  ASSERT_EQ(replaced.replaced_view_ids_size(), 1);
  EXPECT_EQ(replaced.replaced_view_ids(0), old.view_id());
  EXPECT_EQ(Views(), 2);
  // The old image is gone, so it is no duplicate any more.
  EXPECT_EQ(Enroll(View("A", 180, 0)).outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_EQ(Views(), 3);
}

// A v4 database's views have no hash: they are "unknown", never a duplicate, and `replace`
// replaces them by crossing and heading (the way to give an old database its hashes).
TEST_F(CrossingEnrollmentTest, ViewsWithoutAHashAreUnknownAndReplaceReplacesThemByPlace) {
  Enroll(View("A", 0, 0));
  Enroll(View("A", 90, 90));
  {
    auto raw = storage::sqlite::Connection::Open(path_);
    ASSERT_TRUE(raw.ok()) << raw.status();
    ASSERT_TRUE(raw->Exec("UPDATE view SET content_sha256 = NULL").ok());
  }
  Load();
  ASSERT_EQ(Views(), 2);

  EXPECT_EQ(Enroll(View("A", 0, 0)).outcome(), v1::ENROLL_OUTCOME_STORED);  // not known as stored
  EXPECT_EQ(Views(), 3);
  v1::EnrollViewRequest upgrade = View("A", 90, 90);
  upgrade.set_replace(true);
  const v1::EnrollViewResponse upgraded = Enroll(upgrade);
  EXPECT_EQ(upgraded.outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_EQ(upgraded.replaced_view_ids_size(), 1);
  EXPECT_EQ(Views(), 3);
  EXPECT_EQ(Enroll(View("A", 90, 90)).outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
}

// A view's capture position is stored with it, answered for duplicates, survives a reload and
// names the best view of a recognition; `replace` takes the place of the view at the same
// crossing, heading and position only.
TEST_F(CrossingEnrollmentTest, PositionsTellViewsOfOneHeadingApart) {
  v1::EnrollViewRequest kerb = View("A", 0, 0);
  kerb.set_position("north-kerb");
  const v1::EnrollViewResponse stored = Enroll(kerb);
  EXPECT_EQ(stored.outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_EQ(stored.position(), "north-kerb");
  v1::EnrollViewRequest middle = View("A", 0, 120);
  middle.set_position("p2");
  Enroll(middle);
  EXPECT_EQ(Views(), 2);  // the same heading from two positions: two views

  v1::EnrollViewRequest copy = View("B", 90, 0);  // kerb's image again
  EXPECT_EQ(Enroll(copy).position(), "north-kerb");

  v1::EnrollViewRequest reshot = View("A", 0, 240);
  reshot.set_position("p2");
  reshot.set_replace(true);
  const v1::EnrollViewResponse replaced = Enroll(reshot);
  EXPECT_EQ(replaced.replaced_view_ids_size(), 1);  // p2 only, not north-kerb
  EXPECT_EQ(Views(), 2);

  Load();
  v1::RecognizeRequest query;
  query.set_database("campus");
  query.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama_, 0)));
  absl::StatusOr<v1::RecognizeResponse> answer = registry_->Recognize(query);
  ASSERT_TRUE(answer.ok()) << answer.status();
  ASSERT_TRUE(answer->recognized()) << answer->reason();
  EXPECT_EQ(answer->view_id(), stored.view_id());
  EXPECT_EQ(answer->position(), "north-kerb");
  ASSERT_GT(answer->candidates_size(), 0);
  EXPECT_EQ(answer->candidates(0).position(), "north-kerb");

  v1::EnrollViewRequest bad = View("A", 30, 200);
  bad.set_position("two\nlines");
  EXPECT_EQ(registry_->EnrollView(bad).status().code(), absl::StatusCode::kInvalidArgument);
}

// Issue 34: a view taken facing an unknown way is stored with no heading; a recognition that
// picks it answers the crossing and no heading, also after a restart; `replace` takes the
// crossing's view with no heading at the same position.
TEST_F(CrossingEnrollmentTest, AViewWithNoHeadingAnswersItsCrossingOnly) {
  v1::EnrollViewRequest unheaded = View("A", 0, 0);
  unheaded.set_heading_unknown(true);
  const v1::EnrollViewResponse stored = Enroll(unheaded);
  EXPECT_EQ(stored.outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_TRUE(stored.heading_unknown());
  EXPECT_EQ(stored.heading_deg(), 0);
  const v1::EnrollViewResponse headed = Enroll(View("A", 90, 120));
  EXPECT_FALSE(headed.heading_unknown());
  EXPECT_EQ(headed.heading_deg(), 90);
  // The same image again: a duplicate that says the stored view has no heading.
  v1::EnrollViewRequest again = View("B", 30, 0);
  EXPECT_TRUE(Enroll(again).heading_unknown());
  // A heading and "unknown" at once is a mistake.
  v1::EnrollViewRequest both = View("A", 30, 200);
  both.set_heading_unknown(true);
  EXPECT_EQ(registry_->EnrollView(both).status().code(), absl::StatusCode::kInvalidArgument);

  for (int restart = 0; restart < 2; ++restart) {
    if (restart == 1) Load();
    v1::RecognizeRequest query;
    query.set_database("campus");
    query.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama_, 0)));
    absl::StatusOr<v1::RecognizeResponse> answer = registry_->Recognize(query);
    ASSERT_TRUE(answer.ok()) << answer.status();
    ASSERT_TRUE(answer->recognized()) << answer->reason();
    EXPECT_EQ(answer->crossing(), "A");
    EXPECT_EQ(answer->view_id(), stored.view_id());
    EXPECT_TRUE(std::isnan(answer->heading_deg())) << answer->heading_deg();
    ASSERT_GT(answer->candidates_size(), 0);
    EXPECT_TRUE(std::isnan(answer->candidates(0).heading_deg()));
  }

  // Replacing the crossing's view with no heading (same position, ""): the headed one stays.
  v1::EnrollViewRequest reshot = View("A", 0, 240);
  reshot.set_heading_unknown(true);
  reshot.set_replace(true);
  const v1::EnrollViewResponse replaced = Enroll(reshot);
  ASSERT_EQ(replaced.replaced_view_ids_size(), 1);
  EXPECT_EQ(replaced.replaced_view_ids(0), stored.view_id());
  EXPECT_EQ(Views(), 2);
}

// Issue 34: the vocabulary is learnt from exactly the first 16, 32, 64, ... views, however far
// enrollment went on before the worker got to the database. A user's bulk enrollment recorded
// 44, 95, 228 and 301 views: the worker learnt from every view present when it looked. Here a
// database of 44 views loses its vocabulary and a restarted server learns it again: from the
// first 32 (global_stage.cc: crossing::VocabularyScheduleSize and TrainOnFirstImages).
TEST(VocabularyScheduleServiceTest, LearntFromTheFirstViewsOfTheSchedule) {
  TempDir dir;
  const std::string path = dir.File("waymark.db");
  std::unique_ptr<CrossingRegistry> registry = testing::LoadRegistry(path);
  ASSERT_NE(registry, nullptr);
  v1::CreateDatabaseRequest create;
  create.set_name("campus");
  create.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  ASSERT_TRUE(registry->CreateDatabase(create).ok());
  std::vector<cv::Mat> panoramas;
  for (int p = 0; p < 4; ++p) panoramas.push_back(testing::MakePanorama(60 + p));
  for (int n = 0; n < 44; ++n) {
    v1::EnrollViewRequest request;
    request.set_database("campus");
    request.set_crossing("P" + std::to_string(n % 4));
    request.set_heading_deg(360.0 * (n / 4) / 11);
    request.set_create_crossing(true);
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(panoramas[n % 4], 360.0 * (n / 4) / 11)));
    ASSERT_TRUE(registry->EnrollView(request).ok());
  }
  registry->WaitForGlobalStage();
  EXPECT_EQ(registry->GetStats("campus")->vocabulary_views(), 32);
  registry.reset();
  {
    absl::StatusOr<storage::sqlite::Connection> connection =
        storage::sqlite::Connection::Open(path);
    ASSERT_TRUE(connection.ok()) << connection.status();
    ASSERT_TRUE(connection->Exec("DELETE FROM crossing_vocabulary").ok());
  }
  registry = testing::LoadRegistry(path);
  ASSERT_NE(registry, nullptr);
  registry->WaitForGlobalStage();
  const absl::StatusOr<v1::DatabaseStats> stats = registry->GetStats("campus");
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_EQ(stats->vocabulary_views(), 32);  // not 44
  EXPECT_EQ(stats->coded_views(), 44);
}

// Issue 34: what `db create` sends by default (client/cli/db_commands.cc: retrieval, RootSIFT, kept
// aspect) makes a database with the global stage; what `db create --mode paper` sends makes the
// paper's exact configuration (the parameters with which decision_test reproduces Tables 4 and
// 8(d): lambda 0.32, N0 5, N1 10, N2 3, alpha = beta = 0.5, plain SIFT at 320x240, squeezed).
TEST(DefaultDatabaseTest, TheBestMeasuredAndThePapersConfiguration) {
  TempDir dir;
  std::unique_ptr<CrossingRegistry> registry = testing::LoadRegistry(dir.File("waymark.db"));
  ASSERT_NE(registry, nullptr);
  v1::CreateDatabaseRequest best;
  best.set_name("best");
  best.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  best.mutable_params()->set_root_sift(true);
  best.mutable_params()->set_keep_aspect(true);
  absl::StatusOr<v1::CrossingDatabase> made = registry->CreateDatabase(best);
  ASSERT_TRUE(made.ok()) << made.status();
  EXPECT_EQ(made->params().recognition().mode(), v1::RECOGNITION_MODE_RETRIEVAL);
  EXPECT_TRUE(made->params().root_sift());
  EXPECT_TRUE(made->params().keep_aspect());
  EXPECT_TRUE(made->params().global_descriptor());

  v1::CreateDatabaseRequest paper;
  paper.set_name("paper");
  paper.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_PAPER);
  paper.mutable_params()->set_root_sift(false);
  paper.mutable_params()->set_keep_aspect(false);
  made = registry->CreateDatabase(paper);
  ASSERT_TRUE(made.ok()) << made.status();
  const v1::DatabaseParams& p = made->params();
  EXPECT_EQ(p.recognition().mode(), v1::RECOGNITION_MODE_PAPER);
  EXPECT_FALSE(p.root_sift());
  EXPECT_FALSE(p.keep_aspect());
  EXPECT_FALSE(p.global_descriptor());
  EXPECT_EQ(p.work_width(), 320);
  EXPECT_EQ(p.work_height(), 240);
  EXPECT_EQ(p.max_keypoints(), 0);
  EXPECT_EQ(p.cluster_threshold(), 5);
  EXPECT_DOUBLE_EQ(p.recognition().ratio(), 0.32);
  EXPECT_EQ(p.recognition().n0(), 5);
  EXPECT_EQ(p.recognition().n1(), 10);
  EXPECT_EQ(p.recognition().n2(), 3);
  EXPECT_DOUBLE_EQ(p.recognition().alpha(), 0.5);
  EXPECT_DOUBLE_EQ(p.recognition().beta(), 0.5);
}

}  // namespace
}  // namespace waymark::service

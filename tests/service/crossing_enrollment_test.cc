// CrossingRegistry::EnrollView on a real SQLite file, without gRPC: duplicates by image hash,
// `replace`, a database written before hashes were stored (schema v4), whose views have none, and
// capture positions (issue 18).

#include <memory>
#include <string>

#include "gtest/gtest.h"
#include "server/service/crossing_registry.h"
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

}  // namespace
}  // namespace waymark::service

// Several servers on one PostgreSQL database (issue 19), as registries in one process, each with
// its own store and connections, exactly as separate waymark-server processes hold them: what one
// enrolls the others recognize after a sync; two enrolling into one database at once keep the
// one clustering that sequential clustering in enrollment order gives; deletions and new
// databases reach the others; the sync thread follows without being asked.

#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/crossing/crossing_fleet_sync.h"
#include "server/service/crossing/crossing_registry.h"
#include "tests/service/registry_on_file.h"
#include "tests/storage/store_backend.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::service {
namespace {

using storage::testing::Backend;
using storage::testing::TestDatabase;

constexpr int kPlaces = 6;

class CrossingFleetTest : public ::testing::Test {
 protected:
  CrossingFleetTest() : database_(Backend::kPostgres) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    for (int p = 0; p < kPlaces; ++p) panoramas_.push_back(testing::MakePanorama(70 + p));
    a_ = testing::LoadRegistry(database_.db());
    b_ = testing::LoadRegistry(database_.db());
    ASSERT_NE(a_, nullptr);
    ASSERT_NE(b_, nullptr);
  }

  static void Create(CrossingRegistry& registry, v1::RecognitionMode mode) {
    v1::CreateDatabaseRequest create;
    create.set_name("campus");
    create.mutable_params()->mutable_recognition()->set_mode(mode);
    absl::StatusOr<v1::CrossingDatabase> created = registry.CreateDatabase(create);
    ASSERT_TRUE(created.ok()) << created.status();
  }

  // View `n`: places in turn, headings 40 degrees apart.
  v1::EnrollViewRequest View(int n) const {
    v1::EnrollViewRequest request;
    request.set_database("campus");
    request.set_crossing("P" + std::to_string(n % kPlaces));
    request.set_heading_deg(40.0 * (n / kPlaces));
    request.set_create_crossing(true);
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(panoramas_[n % kPlaces], 40.0 * (n / kPlaces))));
    return request;
  }

  static void Enroll(CrossingRegistry& registry, const v1::EnrollViewRequest& request) {
    absl::StatusOr<v1::EnrollViewResponse> answer = registry.EnrollView(request);
    ASSERT_TRUE(answer.ok()) << answer.status();
    ASSERT_EQ(answer->outcome(), v1::ENROLL_OUTCOME_STORED);
  }

  v1::RecognizeResponse Recognize(CrossingRegistry& registry, int place, double heading) {
    v1::RecognizeRequest request;
    request.set_database("campus");
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(panoramas_[place], heading)));
    absl::StatusOr<v1::RecognizeResponse> answer = registry.Recognize(request);
    EXPECT_TRUE(answer.ok()) << answer.status();
    return answer.ok() ? *answer : v1::RecognizeResponse();
  }

  static v1::DatabaseStats Stats(CrossingRegistry& registry) {
    absl::StatusOr<v1::DatabaseStats> stats = registry.GetStats("campus");
    EXPECT_TRUE(stats.ok()) << stats.status();
    return stats.ok() ? *stats : v1::DatabaseStats();
  }

  // Clusters as (centre view, members), in order.
  static std::vector<std::pair<int64_t, int>> Clusters(CrossingRegistry& registry) {
    std::vector<std::pair<int64_t, int>> clusters;
    const v1::DatabaseStats stats = Stats(registry);
    for (const v1::ClusterInfo& c : stats.clusters()) {
      clusters.emplace_back(c.center_view_id(), c.members());
    }
    return clusters;
  }

  TestDatabase database_;
  std::vector<cv::Mat> panoramas_;
  std::unique_ptr<CrossingRegistry> a_;  // two servers on one database
  std::unique_ptr<CrossingRegistry> b_;
};

TEST_F(CrossingFleetTest, WhatOneServerEnrollsTheOtherRecognizesAfterASync) {
  Create(*a_, v1::RECOGNITION_MODE_RETRIEVAL);
  for (int n = 0; n < 18; ++n) Enroll(*a_, View(n));
  a_->WaitForGlobalStage();
  EXPECT_EQ(b_->GetStats("campus").status().code(), absl::StatusCode::kNotFound);

  ASSERT_TRUE(b_->Sync().ok());
  b_->WaitForGlobalStage();
  const v1::DatabaseStats a_stats = Stats(*a_);
  const v1::DatabaseStats b_stats = Stats(*b_);
  EXPECT_EQ(b_stats.database().views(), 18);
  EXPECT_EQ(b_stats.database().crossings(), kPlaces);
  EXPECT_EQ(b_stats.vocabulary_views(), a_stats.vocabulary_views());
  EXPECT_EQ(b_stats.coded_views(), 18);
  EXPECT_EQ(Clusters(*b_), Clusters(*a_));

  // Appends after the first load arrive incrementally, and the answers agree.
  for (int n = 18; n < 24; ++n) Enroll(*a_, View(n));
  a_->WaitForGlobalStage();
  ASSERT_TRUE(b_->Sync().ok());
  b_->WaitForGlobalStage();
  EXPECT_EQ(Stats(*b_).database().views(), 24);
  EXPECT_EQ(Clusters(*b_), Clusters(*a_));
  for (int place = 0; place < kPlaces; ++place) {
    const v1::RecognizeResponse on_a = Recognize(*a_, place, 20.0 + 5 * place);
    const v1::RecognizeResponse on_b = Recognize(*b_, place, 20.0 + 5 * place);
    EXPECT_EQ(on_b.recognized(), on_a.recognized()) << "place " << place;
    EXPECT_EQ(on_b.crossing(), on_a.crossing());
    EXPECT_EQ(on_b.view_id(), on_a.view_id());
  }
}

TEST_F(CrossingFleetTest, TwoServersEnrollingAtOnceKeepTheSequentialClustering) {
  Create(*a_, v1::RECOGNITION_MODE_PAPER);
  ASSERT_TRUE(b_->Sync().ok());
  constexpr int kViews = 24;
  std::thread on_a([&] {
    for (int n = 0; n < kViews; n += 2) Enroll(*a_, View(n));
  });
  std::thread on_b([&] {
    for (int n = 1; n < kViews; n += 2) Enroll(*b_, View(n));
  });
  on_a.join();
  on_b.join();
  ASSERT_TRUE(a_->Sync().ok());
  ASSERT_TRUE(b_->Sync().ok());
  EXPECT_EQ(Stats(*a_).database().views(), kViews);
  EXPECT_EQ(Stats(*b_).database().views(), kViews);
  const auto clusters = Clusters(*a_);
  EXPECT_EQ(Clusters(*b_), clusters);

  // A third server loads what is stored; clustering every view again in enrollment order gives
  // the same clusters: each enrollment saw every view before it, whichever server took it.
  std::unique_ptr<CrossingRegistry> c = testing::LoadRegistry(database_.db());
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(Clusters(*c), clusters);
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database("campus");
  ASSERT_TRUE(c->RebuildClusters(rebuild).ok());
  std::vector<int> rebuilt_sizes, sizes;
  for (const auto& [centre, members] : Clusters(*c)) rebuilt_sizes.push_back(members);
  for (const auto& [centre, members] : clusters) sizes.push_back(members);
  EXPECT_EQ(rebuilt_sizes, sizes);
  std::vector<int64_t> rebuilt_centres, centres;
  for (const auto& [centre, members] : Clusters(*c)) rebuilt_centres.push_back(centre);
  for (const auto& [centre, members] : clusters) centres.push_back(centre);
  EXPECT_EQ(rebuilt_centres, centres);
}

TEST_F(CrossingFleetTest, DeletionsAndNewDatabasesReachTheOtherServer) {
  Create(*a_, v1::RECOGNITION_MODE_PAPER);
  for (int n = 0; n < 12; ++n) Enroll(*a_, View(n));
  ASSERT_TRUE(b_->Sync().ok());
  EXPECT_EQ(Stats(*b_).database().crossings(), kPlaces);

  v1::DeleteCrossingRequest erase;
  erase.set_database("campus");
  erase.set_name("P2");
  ASSERT_TRUE(a_->DeleteCrossing(erase).ok());
  ASSERT_TRUE(b_->Sync().ok());
  EXPECT_EQ(Stats(*b_).database().crossings(), kPlaces - 1);
  EXPECT_EQ(Stats(*b_).database().views(), 10);
  EXPECT_EQ(Clusters(*b_), Clusters(*a_));

  // B enrolls on what it now holds; A follows.
  Enroll(*b_, View(12));
  ASSERT_TRUE(a_->Sync().ok());
  EXPECT_EQ(Stats(*a_).database().views(), 11);

  ASSERT_TRUE(a_->DeleteDatabase("campus").ok());
  ASSERT_TRUE(b_->Sync().ok());
  EXPECT_EQ(b_->GetStats("campus").status().code(), absl::StatusCode::kNotFound);
  // Deleted and created again under the same name: the other server drops the old one.
  Create(*b_, v1::RECOGNITION_MODE_VERIFIED);
  ASSERT_TRUE(a_->Sync().ok());
  EXPECT_EQ(Stats(*a_).database().views(), 0);
  EXPECT_EQ(Stats(*a_).database().params().recognition().mode(), v1::RECOGNITION_MODE_VERIFIED);
}

TEST_F(CrossingFleetTest, TheSyncThreadFollowsTheOtherServerUnasked) {
  std::unique_ptr<CrossingFleetSync> follower = CrossingFleetSync::Start(b_.get());
  ASSERT_NE(follower, nullptr);
  Create(*a_, v1::RECOGNITION_MODE_PAPER);
  Enroll(*a_, View(0));
  Enroll(*a_, View(1));
  // Bounded only so that a broken sync ends the test; a notification arrives in milliseconds.
  int views = 0;
  for (int i = 0; i < 300 && views < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    absl::StatusOr<v1::DatabaseStats> stats = b_->GetStats("campus");
    views = stats.ok() ? stats->database().views() : 0;
  }
  EXPECT_EQ(views, 2);
  EXPECT_GE(follower->syncs(), 1);
}

TEST(CrossingFleetSyncTest, NothingToFollowOnSqlite) {
  TestDatabase sqlite(Backend::kSqlite);
  std::unique_ptr<CrossingRegistry> registry = testing::LoadRegistry(sqlite.db());
  ASSERT_NE(registry, nullptr);
  EXPECT_EQ(CrossingFleetSync::Start(registry.get()), nullptr);
  EXPECT_TRUE(registry->Sync().ok());
}

}  // namespace
}  // namespace waymark::service

// Content hashes of crossing views (schema v5, issue 15): the same image is stored once per
// database, the check holds across connections racing for the file, ReplaceViews swaps views and
// clusters in one transaction, and a v4 file keeps working with its views' hashes unknown.

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "storage/migrations.h"
#include "storage/sha256.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::FakeDigest;
using ::waymark::storage::testing::MakeHashedView;
using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TempDir;
using ::waymark::storage::testing::TestDatabase;

// One suite, both backends (store_backend.h).
class ViewContentTest : public ::testing::TestWithParam<testing::Backend> {
 protected:
  ViewContentTest() : database_(GetParam()) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    ASSERT_OK_AND_ASSIGN(store_, OpenCrossingStore(database_.db()));
    ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store_->CreateDatabase("city", "{}"));
    db_ = db.id;
    ASSERT_OK_AND_ASSIGN(CrossingRecord a, store_->AddCrossing(db_, "A", ""));
    ASSERT_OK_AND_ASSIGN(CrossingRecord b, store_->AddCrossing(db_, "B", ""));
    a_ = a.id;
    b_ = b.id;
  }

  std::vector<ViewRecord> Views() {
    absl::StatusOr<std::vector<ViewRecord>> views = store_->LoadViews(db_);
    EXPECT_TRUE(views.ok()) << views.status();
    return views.ok() ? *views : std::vector<ViewRecord>();
  }

  std::vector<ClusterRecord> Clusters() {
    absl::StatusOr<std::vector<ClusterRecord>> clusters = store_->LoadClusters(db_);
    EXPECT_TRUE(clusters.ok()) << clusters.status();
    return clusters.ok() ? *clusters : std::vector<ClusterRecord>();
  }

  TestDatabase database_;
  std::unique_ptr<CrossingStore> store_;
  int64_t db_ = 0;
  int64_t a_ = 0;
  int64_t b_ = 0;
};

TEST(Sha256Test, KnownDigest) {
  ASSERT_OK_AND_ASSIGN(std::string digest, Sha256("abc"));
  EXPECT_EQ(HexString(digest),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

INSTANTIATE_TEST_SUITE_P(Backends, ViewContentTest, testing::kBothBackends, testing::BackendName);

TEST_P(ViewContentTest, HashRoundTripsAndAnUnknownOneStaysEmpty) {
  ASSERT_OK(store_->AddView(MakeHashedView(a_, 1), {}));
  ASSERT_OK(store_->AddView(MakeView(a_, 2, 7), {}));
  const std::vector<ViewRecord> views = Views();
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].content_sha256, FakeDigest(1));
  EXPECT_EQ(views[1].content_sha256, "");
}

TEST_P(ViewContentTest, TheSameImageIsStoredOncePerDatabase) {
  ASSERT_OK_AND_ASSIGN(AddViewResult first, store_->AddView(MakeHashedView(a_, 1), {}));

  // Same crossing, another crossing, another heading: all the same image.
  for (const ViewRecord& again :
       {MakeHashedView(a_, 1), MakeHashedView(b_, 1), MakeHashedView(a_, 1, 180)}) {
    absl::StatusOr<AddViewResult> added = store_->AddView(again, {});
    EXPECT_EQ(CodeOf(added), absl::StatusCode::kAlreadyExists);
    EXPECT_NE(added.status().message().find("view " + std::to_string(first.view_id) +
                                            " already holds this image"),
              absl::string_view::npos)
        << added.status();
  }
  EXPECT_EQ(CodeOf(store_->AddViewWithNewCrossing({db_, "C", ""}, MakeHashedView(0, 1), {})),
            absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(Views().size(), 1u);
  EXPECT_EQ(Clusters().size(), 1u);
  ASSERT_OK_AND_ASSIGN(std::vector<CrossingRecord> crossings, store_->ListCrossings(db_));
  EXPECT_EQ(crossings.size(), 2u) << "the refused view's new crossing was not created";

  // Another image, unknown images and another database are not duplicates.
  ASSERT_OK(store_->AddView(MakeHashedView(a_, 2), {}));
  ASSERT_OK(store_->AddView(MakeView(a_, 2, 5), {}));
  ASSERT_OK(store_->AddView(MakeView(a_, 2, 5), {}));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord other, store_->CreateDatabase("other", "{}"));
  ASSERT_OK(store_->AddViewWithNewCrossing({other.id, "A", ""}, MakeHashedView(0, 1), {}));
  EXPECT_EQ(Views().size(), 4u);
}

TEST_P(ViewContentTest, AHashThatIsNotADigestIsInvalid) {
  ViewRecord view = MakeView(a_, 2, 1);
  view.content_sha256 = "short";
  EXPECT_EQ(CodeOf(store_->AddView(view, {})), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(Views().empty());
}

// Two stores on one database (two connections) and two threads on each, all adding the same image:
// the check and the insert are one write transaction, so exactly one wins.
TEST_P(ViewContentTest, ConcurrentAddsOfOneImageStoreItOnce) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> second, OpenCrossingStore(database_.db()));
  constexpr int kThreads = 4;
  constexpr int kImages = 10;
  std::atomic<int> stored{0};
  std::atomic<int> duplicates{0};
  std::vector<absl::Status> failures(kThreads);
  std::vector<std::thread> threads;
  const int64_t crossing = a_;
  for (int t = 0; t < kThreads; ++t) {
    CrossingStore* store = t % 2 == 0 ? store_.get() : second.get();
    threads.emplace_back([&, t, store] {
      for (int image = 0; image < kImages; ++image) {
        absl::StatusOr<AddViewResult> added = store->AddView(MakeHashedView(crossing, image), {});
        if (added.ok()) {
          ++stored;
        } else if (absl::IsAlreadyExists(added.status())) {
          ++duplicates;
        } else {
          failures[t] = added.status();
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const absl::Status& failure : failures) EXPECT_TRUE(failure.ok()) << failure;
  EXPECT_EQ(stored.load(), kImages);
  EXPECT_EQ(duplicates.load(), (kThreads - 1) * kImages);
  EXPECT_EQ(Views().size(), static_cast<size_t>(kImages));
}

TEST_P(ViewContentTest, ReplaceViewsSwapsViewsAndClustersInOneGo) {
  ASSERT_OK_AND_ASSIGN(AddViewResult v1, store_->AddView(MakeHashedView(a_, 1, 0), {}));
  ClusterAssignment join;
  join.new_cluster = false;
  join.cluster_id = v1.cluster_id;
  ASSERT_OK_AND_ASSIGN(AddViewResult v2, store_->AddView(MakeHashedView(a_, 2, 90), join));
  ASSERT_OK_AND_ASSIGN(AddViewResult v3, store_->AddView(MakeHashedView(b_, 3, 0), {}));

  // v1 (a centre) is replaced by a new image at A/0; the caller re-clustered the rest: v2 now
  // centres its own cluster, which the new view joins; v3 keeps its own.
  ViewReplacement replacement;
  replacement.database_id = db_;
  replacement.replaced_view_ids = {v1.view_id};
  replacement.clusters = {{0, v2.view_id, {v2.view_id}}, {0, v3.view_id, {v3.view_id}}};
  replacement.view = MakeHashedView(a_, 4, 0);
  replacement.join_cluster = 0;
  ASSERT_OK_AND_ASSIGN(ViewReplacementResult result, store_->ReplaceViews(replacement));
  ASSERT_EQ(result.clusters.size(), 2u);
  EXPECT_EQ(result.added.cluster_id, result.clusters[0].id);
  EXPECT_EQ(result.added.crossing_id, a_);

  const std::vector<ViewRecord> views = Views();
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[0].id, v2.view_id);
  EXPECT_EQ(views[2].id, result.added.view_id);
  EXPECT_EQ(views[2].content_sha256, FakeDigest(4));
  const std::vector<ClusterRecord> clusters = Clusters();
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0].center_view_id, v2.view_id);
  EXPECT_EQ(clusters[0].member_view_ids,
            (std::vector<int64_t>{v2.view_id, result.added.view_id}));
  EXPECT_EQ(clusters[1].member_view_ids, (std::vector<int64_t>{v3.view_id}));

  // The same image moved to a new crossing: the old view goes, its hash is free again.
  ViewReplacement move;
  move.database_id = db_;
  move.replaced_view_ids = {v3.view_id};
  move.clusters = {{0, v2.view_id, {v2.view_id, result.added.view_id}}};
  move.view = MakeHashedView(0, 3, 0);
  move.create_crossing = true;
  move.crossing_name = "C";
  ASSERT_OK_AND_ASSIGN(ViewReplacementResult moved, store_->ReplaceViews(move));
  EXPECT_NE(moved.added.crossing_id, b_);
  EXPECT_NE(moved.added.cluster_id, moved.clusters[0].id);  // a new cluster of its own
  EXPECT_EQ(Views().size(), 3u);
  EXPECT_EQ(Clusters().size(), 2u);
}

TEST_P(ViewContentTest, AFailedReplacementChangesNothing) {
  ASSERT_OK_AND_ASSIGN(AddViewResult v1, store_->AddView(MakeHashedView(a_, 1, 0), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult v2, store_->AddView(MakeHashedView(a_, 2, 90), {}));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord other, store_->CreateDatabase("other", "{}"));
  ASSERT_OK_AND_ASSIGN(AddViewResult foreign,
                       store_->AddViewWithNewCrossing({other.id, "X", ""}, MakeHashedView(0, 9), {}));
  const std::vector<ClusterRecord> clusters_before = Clusters();

  ViewReplacement base;
  base.database_id = db_;
  base.replaced_view_ids = {v1.view_id};
  base.clusters = {{0, v2.view_id, {v2.view_id}}};
  base.view = MakeHashedView(a_, 3, 0);

  ViewReplacement foreign_view = base;  // a view of another database
  foreign_view.replaced_view_ids = {foreign.view_id};
  foreign_view.clusters = {{0, v1.view_id, {v1.view_id}}, {0, v2.view_id, {v2.view_id}}};
  EXPECT_EQ(CodeOf(store_->ReplaceViews(foreign_view)), absl::StatusCode::kNotFound);

  ViewReplacement stale_clusters = base;  // clusters still naming the deleted view
  stale_clusters.clusters = {{0, v1.view_id, {v1.view_id}}, {0, v2.view_id, {v2.view_id}}};
  EXPECT_EQ(CodeOf(store_->ReplaceViews(stale_clusters)), absl::StatusCode::kNotFound);

  ViewReplacement duplicate = base;  // the new image is v2's, which is not replaced
  duplicate.view = MakeHashedView(a_, 2, 0);
  EXPECT_EQ(CodeOf(store_->ReplaceViews(duplicate)), absl::StatusCode::kAlreadyExists);

  ViewReplacement bad_join = base;
  bad_join.join_cluster = 1;
  EXPECT_EQ(CodeOf(store_->ReplaceViews(bad_join)), absl::StatusCode::kInvalidArgument);

  const std::vector<ViewRecord> views = Views();
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].id, v1.view_id);
  const std::vector<ClusterRecord> clusters_after = Clusters();
  ASSERT_EQ(clusters_after.size(), clusters_before.size());
  for (size_t i = 0; i < clusters_after.size(); ++i) {
    EXPECT_EQ(clusters_after[i].id, clusters_before[i].id);
    EXPECT_EQ(clusters_after[i].member_view_ids, clusters_before[i].member_view_ids);
  }
}

// A file a v4 build wrote: its views load with no hash, never count as duplicates, and new views
// get one.
TEST(ViewContentMigrationTest, VersionFourViewsKeepWorkingWithUnknownHashes) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    std::vector<absl::string_view> v4(SchemaMigrations().begin(), SchemaMigrations().begin() + 4);
    ASSERT_OK(ApplyMigrations(connection, v4));
    ASSERT_OK(connection.Exec(
        "INSERT INTO crossing_db (id, name, params, created_at) VALUES (1, 'city', '{}', 1);"
        "INSERT INTO crossing (id, db_id, name) VALUES (1, 1, 'A');"
        "INSERT INTO view (id, crossing_id, heading_deg, width, height, keypoint_count, "
        "  keypoints, descriptors, hue_hist, hue_bins, format_version, image, created_at) "
        "  VALUES (1, 1, 30, 320, 240, 0, x'', x'', x'0000803f', 1, 1, x'ffd8', 1);"
        "INSERT INTO cluster (id, db_id, center_view_id) VALUES (1, 1, 1);"
        "INSERT INTO cluster_member (cluster_id, view_id) VALUES (1, 1);"));
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenSqliteCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(1));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].heading_deg, 30);
  EXPECT_EQ(views[0].content_sha256, "");
  ASSERT_OK_AND_ASSIGN(std::string image, store->LoadViewImage(1));
  EXPECT_EQ(image, "\xff\xd8");

  ASSERT_OK(store->AddView(MakeHashedView(1, 1), {}));
  EXPECT_EQ(CodeOf(store->AddView(MakeHashedView(1, 1), {})), absl::StatusCode::kAlreadyExists);
  ASSERT_OK(store->AddView(MakeView(1, 2, 3), {}));
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(1));
  EXPECT_EQ(views.size(), 3u);

  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, CurrentSchemaVersion());
}

}  // namespace
}  // namespace waymark::storage

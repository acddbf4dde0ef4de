// The CrossingStore on both backends (a SQLite file, a PostgreSQL database): round trips,
// ordering, errors, cascades, atomicity, reopening, two connections, concurrent writers. Row
// counts are read through a separate raw connection so that they show what is really stored.

#include "storage/crossing_store.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "storage/migrations.h"
#include "storage/open_stores.h"
#include "storage/postgres/pg_schema.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TestDatabase;
using ::waymark::storage::testing::TempDir;

bool SameFloats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// Every stored field of `actual` equals `expected` bit for bit (ids and image aside).
void ExpectSameFeatures(const ViewRecord& actual, const ViewRecord& expected) {
  EXPECT_EQ(actual.crossing_id, expected.crossing_id);
  EXPECT_EQ(std::memcmp(&actual.heading_deg, &expected.heading_deg, sizeof(double)), 0);
  EXPECT_EQ(actual.width, expected.width);
  EXPECT_EQ(actual.height, expected.height);
  EXPECT_EQ(actual.keypoint_count, expected.keypoint_count);
  EXPECT_TRUE(SameFloats(actual.keypoints, expected.keypoints));
  EXPECT_EQ(actual.descriptors, expected.descriptors);
  EXPECT_TRUE(SameFloats(actual.hue_hist, expected.hue_hist));
  EXPECT_EQ(actual.format_version, expected.format_version);
}

// The suite runs on both backends (store_backend.h): a SQLite file, a PostgreSQL database.
class CrossingStoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  CrossingStoreTest() : database_(GetParam(), "var/lib/waymark/waymark.db") {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    // On SQLite the nested path also checks that the parent directories are created.
    absl::StatusOr<std::unique_ptr<CrossingStore>> store = OpenCrossingStore(database_.db());
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = std::move(*store);
  }

  // Rows of `table` (optionally filtered), as the database holds them.
  int64_t Count(const std::string& table, const std::string& where = "") {
    absl::StatusOr<int64_t> count = database_.CountRows(table, where);
    if (!count.ok()) {
      ADD_FAILURE() << count.status();
      return -1;
    }
    return *count;
  }

  // All row counts, to show that a failed call changed nothing.
  std::vector<int64_t> AllCounts() {
    return {Count("crossing_db"), Count("crossing"), Count("view"), Count("cluster"),
            Count("cluster_member")};
  }

  // A database with one crossing; returns {database id, crossing id}.
  std::pair<int64_t, int64_t> MakeDatabaseWithCrossing(const std::string& db_name,
                                                       const std::string& crossing_name = "c1") {
    absl::StatusOr<DatabaseRecord> db = store_->CreateDatabase(db_name, "{}");
    EXPECT_TRUE(db.ok()) << db.status();
    absl::StatusOr<CrossingRecord> crossing = store_->AddCrossing(db->id, crossing_name, "label");
    EXPECT_TRUE(crossing.ok()) << crossing.status();
    return {db->id, crossing->id};
  }

  TestDatabase database_;
  std::unique_ptr<CrossingStore> store_;
};

INSTANTIATE_TEST_SUITE_P(Backends, CrossingStoreTest, testing::kBothBackends,
                         testing::BackendName);

// --- Opening and schema ----------------------------------------------------------------------

TEST_P(CrossingStoreTest, OpenCreatesParentDirectoryAndMigrates) {
  if (GetParam() == Backend::kSqlite) {
    EXPECT_TRUE(std::filesystem::exists(database_.db()));
    ASSERT_OK_AND_ASSIGN(int64_t version, database_.QueryInt("PRAGMA user_version"));
    EXPECT_EQ(version, CurrentSchemaVersion());
  } else {
    ASSERT_OK_AND_ASSIGN(int64_t version, database_.QueryInt("SELECT version FROM waymark_schema"));
    EXPECT_EQ(version, static_cast<int64_t>(pg::PostgresMigrations().size()));
  }
}

TEST(CrossingStoreOpenTest, InMemoryStoreWorksAndIsPrivate) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> a, OpenSqliteCrossingStore(":memory:"));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> b, OpenSqliteCrossingStore(":memory:"));
  ASSERT_OK(a->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(std::vector<DatabaseRecord> in_b, b->ListDatabases());
  EXPECT_TRUE(in_b.empty());
}

TEST(CrossingStoreOpenTest, FileFromNewerBuildIsRefused) {
  TempDir dir;
  const std::string path = dir.File("future.db");
  {
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    ASSERT_OK(connection.Exec("PRAGMA user_version = 999"));
  }
  absl::StatusOr<std::unique_ptr<CrossingStore>> store = OpenSqliteCrossingStore(path);
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(store.status().message().find("999"), absl::string_view::npos) << store.status();
}

TEST(CrossingStoreOpenTest, UncreatableDirectoryIsAnError) {
  TempDir dir;
  const std::string blocker = dir.File("file");
  { ASSERT_OK_AND_ASSIGN(sqlite::Connection c, sqlite::Connection::Open(blocker)); }
  // The parent "directory" is a regular file.
  EXPECT_FALSE(OpenSqliteCrossingStore(blocker + "/sub/waymark.db").ok());
}

// --- Databases ----------------------------------------------------------------------------------

TEST_P(CrossingStoreTest, CreateGetListAndUpdateDatabases) {
  ASSERT_OK_AND_ASSIGN(DatabaseRecord zurich, store_->CreateDatabase("zurich", R"({"k":1})"));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord bern, store_->CreateDatabase("bern", "{}"));
  EXPECT_GT(zurich.id, 0);
  EXPECT_NE(zurich.id, bern.id);
  EXPECT_GT(zurich.created_at, 1.6e9);  // unix seconds, not milliseconds or zero

  ASSERT_OK_AND_ASSIGN(DatabaseRecord got, store_->GetDatabase("zurich"));
  EXPECT_EQ(got.id, zurich.id);
  EXPECT_EQ(got.params, R"({"k":1})");
  EXPECT_EQ(got.created_at, zurich.created_at);

  ASSERT_OK_AND_ASSIGN(std::vector<DatabaseRecord> all, store_->ListDatabases());
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "bern");  // by name
  EXPECT_EQ(all[1].name, "zurich");

  ASSERT_OK(store_->UpdateDatabaseParams(zurich.id, R"({"k":2})"));
  ASSERT_OK_AND_ASSIGN(got, store_->GetDatabase("zurich"));
  EXPECT_EQ(got.params, R"({"k":2})");
}

TEST_P(CrossingStoreTest, DuplicateDatabaseNameIsAlreadyExists) {
  ASSERT_OK(store_->CreateDatabase("city", "{}"));
  absl::StatusOr<DatabaseRecord> again = store_->CreateDatabase("city", "{}");
  EXPECT_EQ(again.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(again.status().message(), "database \"city\" already exists");
  EXPECT_EQ(Count("crossing_db"), 1);
}

TEST_P(CrossingStoreTest, UnknownDatabaseIsNotFoundEverywhere) {
  absl::StatusOr<DatabaseRecord> get = store_->GetDatabase("foo");
  EXPECT_EQ(get.status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(get.status().message(), "database \"foo\" not found");
  EXPECT_EQ(store_->DeleteDatabase("foo").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->UpdateDatabaseParams(42, "{}").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->AddCrossing(42, "c", "")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->ListCrossings(42)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->LoadViews(42)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->LoadClusters(42)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->ReplaceClusters(42, {})), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->DeleteCrossing(42, 1, {})), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->ListCrossings(42).status().message(), "database 42 not found");
}

TEST_P(CrossingStoreTest, EmptyNamesAreInvalid) {
  EXPECT_EQ(CodeOf(store_->CreateDatabase("", "{}")), absl::StatusCode::kInvalidArgument);
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store_->CreateDatabase("city", "{}"));
  EXPECT_EQ(CodeOf(store_->AddCrossing(db.id, "", "")), absl::StatusCode::kInvalidArgument);
}

TEST_P(CrossingStoreTest, DeleteDatabaseCascadesToEverythingItOwns) {
  auto [doomed, doomed_crossing] = MakeDatabaseWithCrossing("doomed");
  auto [kept, kept_crossing] = MakeDatabaseWithCrossing("kept");
  for (int i = 0; i < 3; ++i) {
    ASSERT_OK(store_->AddView(MakeView(doomed_crossing, 4, i), {}));
    ASSERT_OK(store_->AddView(MakeView(kept_crossing, 4, i), {}));
  }
  ASSERT_OK(store_->AddCrossing(doomed, "c2", ""));
  ASSERT_EQ(AllCounts(), (std::vector<int64_t>{2, 3, 6, 6, 6}));

  ASSERT_OK(store_->DeleteDatabase("doomed"));
  EXPECT_EQ(AllCounts(), (std::vector<int64_t>{1, 1, 3, 3, 3}));
  EXPECT_EQ(Count("crossing", "db_id = " + std::to_string(doomed)), 0);
  EXPECT_EQ(Count("cluster", "db_id = " + std::to_string(doomed)), 0);
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> kept_views, store_->LoadViews(kept));
  EXPECT_EQ(kept_views.size(), 3u);
  EXPECT_EQ(CodeOf(store_->GetDatabase("doomed")), absl::StatusCode::kNotFound);
}

// --- Crossings ----------------------------------------------------------------------------------

TEST_P(CrossingStoreTest, CrossingNamesAreUniquePerDatabase) {
  auto [city, first] = MakeDatabaseWithCrossing("city", "main-square");
  absl::StatusOr<CrossingRecord> again = store_->AddCrossing(city, "main-square", "");
  EXPECT_EQ(again.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(again.status().message(),
            "crossing \"main-square\" in database \"city\" already exists");

  // The same name in another database is a different crossing.
  ASSERT_OK_AND_ASSIGN(DatabaseRecord town, store_->CreateDatabase("town", "{}"));
  ASSERT_OK(store_->AddCrossing(town.id, "main-square", ""));

  ASSERT_OK_AND_ASSIGN(CrossingRecord second, store_->AddCrossing(city, "station", "Bahnhof"));
  ASSERT_OK_AND_ASSIGN(std::vector<CrossingRecord> crossings, store_->ListCrossings(city));
  ASSERT_EQ(crossings.size(), 2u);
  EXPECT_EQ(crossings[0].id, first);
  EXPECT_EQ(crossings[1].id, second.id);
  EXPECT_EQ(crossings[1].name, "station");
  EXPECT_EQ(crossings[1].label, "Bahnhof");
  EXPECT_EQ(crossings[1].database_id, city);
}

// --- Views --------------------------------------------------------------------------------------

TEST_P(CrossingStoreTest, ViewRoundTripIsBitExact) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ViewRecord view = MakeView(crossing, 50, 3, -123.456789);
  // Values a text or lossy encoding would alter.
  view.keypoints[0] = -0.0f;
  view.keypoints[1] = std::numeric_limits<float>::denorm_min();
  view.keypoints[2] = std::numeric_limits<float>::infinity();
  view.keypoints[3] = std::nextafter(1.0f, 2.0f);
  for (int i = 0; i < 256; ++i) view.descriptors[i] = static_cast<uint8_t>(i);
  view.hue_hist.assign(180, 1.0f / 180.0f);
  view.format_version = 7;
  view.image = std::string("\x89PNG\r\n\x1a\n\0\xff", 10);

  ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(view, {}));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store_->LoadViews(db));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].id, added.view_id);
  ExpectSameFeatures(views[0], view);
  EXPECT_TRUE(views[0].image.empty());  // LoadViews never carries image bytes

  ASSERT_OK_AND_ASSIGN(std::string image, store_->LoadViewImage(added.view_id));
  EXPECT_EQ(image, view.image);
}

TEST_P(CrossingStoreTest, ViewWithoutKeypointsOrImage) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ViewRecord empty = MakeView(crossing, 0, 1);
  empty.hue_hist.clear();
  ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(empty, {}));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store_->LoadViews(db));
  ASSERT_EQ(views.size(), 1u);
  ExpectSameFeatures(views[0], empty);

  absl::StatusOr<std::string> image = store_->LoadViewImage(added.view_id);
  EXPECT_EQ(image.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(image.status().message().find("no stored image"), absl::string_view::npos);
  EXPECT_EQ(store_->LoadViewImage(added.view_id + 100).status().message(),
            "view " + std::to_string(added.view_id + 100) + " not found");
}

TEST_P(CrossingStoreTest, LoadViewsIsInEnrollmentOrderAcrossCrossings) {
  auto [db, north] = MakeDatabaseWithCrossing("city", "north");
  ASSERT_OK_AND_ASSIGN(CrossingRecord south, store_->AddCrossing(db, "south", ""));
  auto [other_db, other_crossing] = MakeDatabaseWithCrossing("other");

  std::vector<int64_t> enrolled;
  for (int i = 0; i < 6; ++i) {
    const int64_t crossing = i % 2 == 0 ? south.id : north;  // interleave crossings
    ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(MakeView(crossing, 2, i), {}));
    enrolled.push_back(added.view_id);
    ASSERT_OK(store_->AddView(MakeView(other_crossing, 2, i), {}));  // interleave databases
  }
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store_->LoadViews(db));
  ASSERT_EQ(views.size(), enrolled.size());
  for (size_t i = 0; i < views.size(); ++i) {
    EXPECT_EQ(views[i].id, enrolled[i]);
    EXPECT_EQ(views[i].keypoints[0], static_cast<float>(i));  // seed i
  }

  // Ids keep increasing after deletions: a new view never reuses the deleted highest id.
  ASSERT_OK_AND_ASSIGN(AddViewResult highest, store_->AddView(MakeView(north, 1, 99), {}));
  ASSERT_OK(store_->DeleteCrossing(db, north, {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult later, store_->AddView(MakeView(south.id, 1, 0), {}));
  EXPECT_GT(later.view_id, highest.view_id);
}

TEST_P(CrossingStoreTest, InconsistentBlobSizesAreInvalidAndWriteNothing) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  const std::vector<int64_t> before = AllCounts();

  ViewRecord short_keypoints = MakeView(crossing, 3, 0);
  short_keypoints.keypoints.pop_back();
  absl::StatusOr<AddViewResult> result = store_->AddView(short_keypoints, {});
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("keypoint floats"), absl::string_view::npos);

  ViewRecord long_descriptors = MakeView(crossing, 3, 0);
  long_descriptors.descriptors.push_back(0);
  result = store_->AddView(long_descriptors, {});
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("descriptor bytes"), absl::string_view::npos);

  ViewRecord negative = MakeView(crossing, 0, 0);
  negative.keypoint_count = -1;
  EXPECT_EQ(CodeOf(store_->AddView(negative, {})), absl::StatusCode::kInvalidArgument);

  ViewRecord nan_heading = MakeView(crossing, 1, 0, std::nan(""));
  EXPECT_EQ(CodeOf(store_->AddView(nan_heading, {})), absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(AllCounts(), before);
}

TEST_P(CrossingStoreTest, CorruptStoredBlobIsDataLoss) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(MakeView(crossing, 2, 0), {}));
  const bool sqlite = GetParam() == Backend::kSqlite;
  const std::string id = std::to_string(added.view_id);
  ASSERT_OK(database_.Exec(std::string("UPDATE view SET descriptors = ") +
                           (sqlite ? "x'00'" : "'\\x00'::bytea") + " WHERE id = " + id));
  absl::StatusOr<std::vector<ViewRecord>> views = store_->LoadViews(db);
  EXPECT_EQ(views.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(views.status().message().find("descriptors"), absl::string_view::npos)
      << views.status();

  ASSERT_OK(database_.Exec(
      sqlite ? "UPDATE view SET descriptors = zeroblob(256), hue_hist = x'0000' WHERE id = " + id
             : "UPDATE view SET descriptors = decode(repeat('00', 256), 'hex'), "
               "hue_hist = '\\x0000'::bytea WHERE id = " + id));
  EXPECT_EQ(CodeOf(store_->LoadViews(db)), absl::StatusCode::kDataLoss);
}

// --- Clusters -----------------------------------------------------------------------------------

TEST_P(CrossingStoreTest, AddViewCreatesOrJoinsClusters) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ASSERT_OK_AND_ASSIGN(AddViewResult a, store_->AddView(MakeView(crossing, 1, 0), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult b, store_->AddView(MakeView(crossing, 1, 1), {}));
  ClusterAssignment join_a;
  join_a.new_cluster = false;
  join_a.cluster_id = a.cluster_id;
  ASSERT_OK_AND_ASSIGN(AddViewResult c, store_->AddView(MakeView(crossing, 1, 2), join_a));
  EXPECT_EQ(c.cluster_id, a.cluster_id);
  EXPECT_NE(b.cluster_id, a.cluster_id);

  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> clusters, store_->LoadClusters(db));
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0].id, a.cluster_id);
  EXPECT_EQ(clusters[0].center_view_id, a.view_id);
  EXPECT_EQ(clusters[0].member_view_ids, (std::vector<int64_t>{a.view_id, c.view_id}));
  EXPECT_EQ(clusters[1].center_view_id, b.view_id);
  EXPECT_EQ(clusters[1].member_view_ids, (std::vector<int64_t>{b.view_id}));
}

TEST_P(CrossingStoreTest, FailingAddViewLeavesNothingBehind) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  auto [other_db, other_crossing] = MakeDatabaseWithCrossing("other");
  ASSERT_OK_AND_ASSIGN(AddViewResult foreign, store_->AddView(MakeView(other_crossing, 1, 0), {}));
  const std::vector<int64_t> before = AllCounts();

  // An unknown cluster: the view row was already inserted when the check fails.
  ClusterAssignment unknown;
  unknown.new_cluster = false;
  unknown.cluster_id = 9999;
  absl::StatusOr<AddViewResult> result = store_->AddView(MakeView(crossing, 5, 0), unknown);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(result.status().message(), "cluster 9999 not found");
  EXPECT_EQ(AllCounts(), before);

  // A cluster of another database.
  ClusterAssignment other;
  other.new_cluster = false;
  other.cluster_id = foreign.cluster_id;
  result = store_->AddView(MakeView(crossing, 5, 0), other);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(AllCounts(), before);

  // An unknown crossing.
  result = store_->AddView(MakeView(12345, 5, 0), {});
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(result.status().message(), "crossing 12345 not found");
  EXPECT_EQ(AllCounts(), before);

  // The store is still usable after the rollbacks.
  ASSERT_OK(store_->AddView(MakeView(crossing, 5, 0), {}));
}

// Enrolling the first view of a new crossing creates both in one transaction: a view that cannot
// be stored leaves no empty crossing behind.
TEST_P(CrossingStoreTest, AddViewWithNewCrossingIsAllOrNothing) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ASSERT_OK_AND_ASSIGN(AddViewResult added,
                       store_->AddViewWithNewCrossing({db, "new", "label"}, MakeView(0, 3, 1), {}));
  EXPECT_NE(added.crossing_id, crossing);
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store_->LoadViews(db));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].id, added.view_id);
  EXPECT_EQ(views[0].crossing_id, added.crossing_id);
  EXPECT_EQ(Count("cluster_member", "view_id = " + std::to_string(added.view_id)), 1);
  const std::vector<int64_t> before = AllCounts();

  ClusterAssignment unknown;
  unknown.new_cluster = false;
  unknown.cluster_id = 9999;
  EXPECT_EQ(CodeOf(store_->AddViewWithNewCrossing({db, "doomed", ""}, MakeView(0, 3, 2), unknown)),
            absl::StatusCode::kNotFound);
  ViewRecord inconsistent = MakeView(0, 3, 2);
  inconsistent.descriptors.pop_back();
  EXPECT_EQ(CodeOf(store_->AddViewWithNewCrossing({db, "doomed", ""}, inconsistent, {})),
            absl::StatusCode::kInvalidArgument);
  absl::StatusOr<AddViewResult> taken =
      store_->AddViewWithNewCrossing({db, "c1", ""}, MakeView(0, 3, 2), {});
  EXPECT_EQ(CodeOf(taken), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(taken.status().message(), "crossing \"c1\" in database \"city\" already exists");
  EXPECT_EQ(CodeOf(store_->AddViewWithNewCrossing({db + 100, "x", ""}, MakeView(0, 3, 2), {})),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(AllCounts(), before);
  EXPECT_EQ(Count("crossing", "name = 'doomed'"), 0);
}

TEST_P(CrossingStoreTest, ReplaceClustersReassignsIdsAndKeepsTheGivenOrder) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  std::vector<int64_t> v;
  for (int i = 0; i < 4; ++i) {
    ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(MakeView(crossing, 1, i), {}));
    v.push_back(added.view_id);
  }
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> old_clusters, store_->LoadClusters(db));
  ASSERT_EQ(old_clusters.size(), 4u);

  // Centre first, then the others, as the clustering produces them.
  std::vector<ClusterRecord> wanted(2);
  wanted[0].center_view_id = v[3];
  wanted[0].member_view_ids = {v[3], v[0], v[2]};
  wanted[1].center_view_id = v[1];
  wanted[1].member_view_ids = {v[1]};
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> replaced, store_->ReplaceClusters(db, wanted));
  ASSERT_EQ(replaced.size(), 2u);
  EXPECT_EQ(replaced[0].center_view_id, v[3]);
  EXPECT_EQ(replaced[0].member_view_ids, wanted[0].member_view_ids);
  EXPECT_GT(replaced[0].id, old_clusters.back().id);  // new ids, never reused
  EXPECT_GT(replaced[1].id, replaced[0].id);

  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> loaded, store_->LoadClusters(db));
  ASSERT_EQ(loaded.size(), 2u);
  EXPECT_EQ(loaded[0].id, replaced[0].id);
  EXPECT_EQ(loaded[0].center_view_id, v[3]);
  EXPECT_EQ(loaded[0].member_view_ids, (std::vector<int64_t>{v[0], v[2], v[3]}));  // id order
  EXPECT_EQ(loaded[1].member_view_ids, (std::vector<int64_t>{v[1]}));
  EXPECT_EQ(Count("cluster"), 2);
  EXPECT_EQ(Count("cluster_member"), 4);
}

TEST_P(CrossingStoreTest, InvalidReplacementKeepsTheOldClusters) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  auto [other_db, other_crossing] = MakeDatabaseWithCrossing("other");
  ASSERT_OK_AND_ASSIGN(AddViewResult a, store_->AddView(MakeView(crossing, 1, 0), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult b, store_->AddView(MakeView(crossing, 1, 1), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult foreign, store_->AddView(MakeView(other_crossing, 1, 0), {}));
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> before, store_->LoadClusters(db));
  const std::vector<int64_t> counts = AllCounts();

  // The bad cluster comes second, so the first one was already inserted when the check fails.
  std::vector<ClusterRecord> bad(2);
  bad[0].center_view_id = a.view_id;
  bad[0].member_view_ids = {a.view_id};

  bad[1].center_view_id = b.view_id;
  bad[1].member_view_ids = {a.view_id};  // centre missing from its members
  EXPECT_EQ(CodeOf(store_->ReplaceClusters(db, bad)), absl::StatusCode::kInvalidArgument);

  bad[1].member_view_ids = {b.view_id, b.view_id};  // duplicate member
  EXPECT_EQ(CodeOf(store_->ReplaceClusters(db, bad)), absl::StatusCode::kInvalidArgument);

  bad[1].member_view_ids = {b.view_id, foreign.view_id};  // view of another database
  EXPECT_EQ(CodeOf(store_->ReplaceClusters(db, bad)), absl::StatusCode::kInvalidArgument);

  bad[1].member_view_ids = {b.view_id, 777777};  // unknown view
  EXPECT_EQ(CodeOf(store_->ReplaceClusters(db, bad)), absl::StatusCode::kNotFound);

  EXPECT_EQ(AllCounts(), counts);
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> after, store_->LoadClusters(db));
  ASSERT_EQ(after.size(), before.size());
  for (size_t i = 0; i < after.size(); ++i) {
    EXPECT_EQ(after[i].id, before[i].id);
    EXPECT_EQ(after[i].member_view_ids, before[i].member_view_ids);
  }
}

// --- DeleteCrossing -----------------------------------------------------------------------------

TEST_P(CrossingStoreTest, DeleteCrossingRemovesItsViewsAndReplacesClusters) {
  auto [db, doomed] = MakeDatabaseWithCrossing("city", "doomed");
  ASSERT_OK_AND_ASSIGN(CrossingRecord kept, store_->AddCrossing(db, "kept", ""));
  ASSERT_OK_AND_ASSIGN(AddViewResult d0, store_->AddView(MakeView(doomed, 1, 0), {}));
  ClusterAssignment join_d0;
  join_d0.new_cluster = false;
  join_d0.cluster_id = d0.cluster_id;
  ASSERT_OK_AND_ASSIGN(AddViewResult k0, store_->AddView(MakeView(kept.id, 1, 1), join_d0));
  ASSERT_OK_AND_ASSIGN(AddViewResult d1, store_->AddView(MakeView(doomed, 1, 2), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult k1, store_->AddView(MakeView(kept.id, 1, 3), {}));
  (void)d1;

  std::vector<ClusterRecord> remaining(1);
  remaining[0].center_view_id = k1.view_id;
  remaining[0].member_view_ids = {k1.view_id, k0.view_id};
  ASSERT_OK_AND_ASSIGN(int deleted, store_->DeleteCrossing(db, doomed, remaining));
  EXPECT_EQ(deleted, 2);

  ASSERT_OK_AND_ASSIGN(std::vector<CrossingRecord> crossings, store_->ListCrossings(db));
  ASSERT_EQ(crossings.size(), 1u);
  EXPECT_EQ(crossings[0].id, kept.id);
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store_->LoadViews(db));
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].id, k0.view_id);
  EXPECT_EQ(views[1].id, k1.view_id);
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> clusters, store_->LoadClusters(db));
  ASSERT_EQ(clusters.size(), 1u);
  EXPECT_EQ(clusters[0].center_view_id, k1.view_id);
  EXPECT_EQ(clusters[0].member_view_ids, (std::vector<int64_t>{k0.view_id, k1.view_id}));
  EXPECT_EQ(AllCounts(), (std::vector<int64_t>{1, 1, 2, 1, 2}));
}

TEST_P(CrossingStoreTest, DeleteCrossingWithBadClustersChangesNothing) {
  auto [db, doomed] = MakeDatabaseWithCrossing("city", "doomed");
  ASSERT_OK_AND_ASSIGN(CrossingRecord kept, store_->AddCrossing(db, "kept", ""));
  ASSERT_OK_AND_ASSIGN(AddViewResult d0, store_->AddView(MakeView(doomed, 1, 0), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult k0, store_->AddView(MakeView(kept.id, 1, 1), {}));
  const std::vector<int64_t> before = AllCounts();

  // The caller's clusters still reference a view of the crossing being deleted.
  std::vector<ClusterRecord> stale(1);
  stale[0].center_view_id = k0.view_id;
  stale[0].member_view_ids = {k0.view_id, d0.view_id};
  absl::StatusOr<int> result = store_->DeleteCrossing(db, doomed, stale);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(result.status().message().find("view " + std::to_string(d0.view_id) + " not found"),
            absl::string_view::npos)
      << result.status();

  EXPECT_EQ(AllCounts(), before);
  ASSERT_OK_AND_ASSIGN(std::vector<CrossingRecord> crossings, store_->ListCrossings(db));
  EXPECT_EQ(crossings.size(), 2u);
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> clusters, store_->LoadClusters(db));
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0].center_view_id, d0.view_id);
}

TEST_P(CrossingStoreTest, DeleteCrossingOfAnotherDatabaseIsNotFound) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  auto [other_db, other_crossing] = MakeDatabaseWithCrossing("other");
  absl::StatusOr<int> result = store_->DeleteCrossing(db, other_crossing, {});
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(result.status().message(),
            "crossing " + std::to_string(other_crossing) + " not found in database \"city\"");
  EXPECT_EQ(CodeOf(store_->DeleteCrossing(db, 5555, {})), absl::StatusCode::kNotFound);
  EXPECT_EQ(Count("crossing"), 2);
}

// --- Persistence and sharing --------------------------------------------------------------------

TEST_P(CrossingStoreTest, ReopeningTheFileGivesTheSameData) {
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  std::vector<ViewRecord> written;
  for (int i = 0; i < 3; ++i) {
    ViewRecord view = MakeView(crossing, 10 + i, i, 10.0 * i);
    view.image = "jpeg-bytes-" + std::to_string(i);
    ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(view, {}));
    view.id = added.view_id;
    written.push_back(view);
  }
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> clusters_before, store_->LoadClusters(db));
  store_.reset();  // closes the connection (and checkpoints the WAL)

  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> reopened, OpenCrossingStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord record, reopened->GetDatabase("city"));
  EXPECT_EQ(record.id, db);
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, reopened->LoadViews(db));
  ASSERT_EQ(views.size(), written.size());
  for (size_t i = 0; i < views.size(); ++i) {
    EXPECT_EQ(views[i].id, written[i].id);
    ExpectSameFeatures(views[i], written[i]);
    ASSERT_OK_AND_ASSIGN(std::string image, reopened->LoadViewImage(views[i].id));
    EXPECT_EQ(image, written[i].image);
  }
  ASSERT_OK_AND_ASSIGN(std::vector<ClusterRecord> clusters, reopened->LoadClusters(db));
  ASSERT_EQ(clusters.size(), clusters_before.size());
  for (size_t i = 0; i < clusters.size(); ++i) {
    EXPECT_EQ(clusters[i].id, clusters_before[i].id);
    EXPECT_EQ(clusters[i].member_view_ids, clusters_before[i].member_view_ids);
  }
}

TEST_P(CrossingStoreTest, TwoStoresOnOneFileSeeEachOthersCommits) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> second, OpenCrossingStore(database_.db()));
  auto [db, crossing] = MakeDatabaseWithCrossing("city");
  ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(MakeView(crossing, 3, 0), {}));

  ASSERT_OK_AND_ASSIGN(DatabaseRecord seen, second->GetDatabase("city"));
  EXPECT_EQ(seen.id, db);
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, second->LoadViews(db));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].id, added.view_id);

  // And the other way round; the name constraint spans both connections.
  ASSERT_OK(second->AddCrossing(db, "from-second", ""));
  ASSERT_OK_AND_ASSIGN(std::vector<CrossingRecord> crossings, store_->ListCrossings(db));
  EXPECT_EQ(crossings.size(), 2u);
  EXPECT_EQ(CodeOf(store_->AddCrossing(db, "from-second", "")), absl::StatusCode::kAlreadyExists);
}

TEST_P(CrossingStoreTest, ConcurrentWritersThroughOneAndTwoStoresAllSucceed) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> second, OpenCrossingStore(database_.db()));
  // Plain variables: C++17 lambdas cannot capture structured bindings.
  const auto [db_id, crossing_id] = MakeDatabaseWithCrossing("city");
  const int64_t db = db_id;
  const int64_t crossing = crossing_id;
  constexpr int kThreads = 4;
  constexpr int kViewsPerThread = 20;
  std::vector<absl::Status> failures(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    // Two threads share each store (its mutex), the stores compete for the file (busy_timeout).
    CrossingStore* store = t % 2 == 0 ? store_.get() : second.get();
    threads.emplace_back([&failures, t, store, db, crossing] {
      for (int i = 0; i < kViewsPerThread; ++i) {
        absl::StatusOr<AddViewResult> added =
            store->AddView(MakeView(crossing, 8, t * 100 + i), {});
        if (!added.ok()) {
          failures[t] = added.status();
          return;
        }
        absl::StatusOr<std::vector<ViewRecord>> views = store->LoadViews(db);
        if (!views.ok()) {
          failures[t] = views.status();
          return;
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const absl::Status& failure : failures) EXPECT_TRUE(failure.ok()) << failure;
  EXPECT_EQ(Count("view"), kThreads * kViewsPerThread);
  EXPECT_EQ(Count("cluster_member"), kThreads * kViewsPerThread);
}

}  // namespace
}  // namespace waymark::storage

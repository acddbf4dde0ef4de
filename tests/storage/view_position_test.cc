// Capture positions of crossing views (schema v6, issue 18): stored and loaded with the view, kept
// by ReplaceViews, and a v5 file keeps working with its views untagged. Views with no heading
// (schema v13 / PostgreSQL v4, issue 34), on both backends, and a v12 file's views keep theirs.

#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "storage/migrations.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::MakeHashedView;
using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TempDir;
using ::waymark::storage::testing::TestDatabase;

// One suite, both backends (store_backend.h).
class ViewPositionTest : public ::testing::TestWithParam<testing::Backend> {};
INSTANTIATE_TEST_SUITE_P(Backends, ViewPositionTest, testing::kBothBackends, testing::BackendName);

TEST_P(ViewPositionTest, PositionIsStoredAndLoadedWithTheView) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenCrossingStore(database.db()));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store->AddCrossing(db.id, "A", ""));
  ViewRecord kerb = MakeView(a.id, 2, 1, 30);
  kerb.position = "north-kerb";
  ASSERT_OK(store->AddView(kerb, {}));
  ASSERT_OK(store->AddView(MakeView(a.id, 2, 2, 30), {}));  // untagged
  ViewRecord frame = MakeHashedView(0, 3, 0);
  frame.position = "t=12.5s";
  ASSERT_OK(store->AddViewWithNewCrossing({db.id, "B", ""}, frame, {}));

  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[0].position, "north-kerb");
  EXPECT_EQ(views[1].position, "");
  EXPECT_EQ(views[2].position, "t=12.5s");

  ViewReplacement replacement;
  replacement.database_id = db.id;
  replacement.replaced_view_ids = {views[0].id};
  replacement.view = MakeView(a.id, 2, 4, 30);
  replacement.view.position = "south-kerb";
  ASSERT_OK(store->ReplaceViews(replacement));
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[2].position, "south-kerb");
}

// A file a v5 build wrote: its views load untagged (position ""), and new views get theirs.
TEST(ViewPositionMigrationTest, VersionFiveViewsLoadUntagged) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    std::vector<absl::string_view> v5(SchemaMigrations().begin(), SchemaMigrations().begin() + 5);
    ASSERT_OK(ApplyMigrations(connection, v5));
    ASSERT_OK(connection.Exec(
        "INSERT INTO crossing_db (id, name, params, created_at) VALUES (1, 'city', '{}', 1);"
        "INSERT INTO crossing (id, db_id, name) VALUES (1, 1, 'A');"
        "INSERT INTO view (id, crossing_id, heading_deg, width, height, keypoint_count, "
        "  keypoints, descriptors, hue_hist, hue_bins, format_version, created_at) "
        "  VALUES (1, 1, 30, 320, 240, 0, x'', x'', x'0000803f', 1, 1, 1);"));
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenSqliteCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(1));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].heading_deg, 30);
  EXPECT_EQ(views[0].position, "");

  ViewRecord tagged = MakeView(1, 2, 2);
  tagged.position = "p2";
  ASSERT_OK(store->AddView(tagged, {}));
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(1));
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[1].position, "p2");

  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, CurrentSchemaVersion());
}

TEST_P(ViewPositionTest, AViewWithNoHeadingIsStoredAndLoadedWithout) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenCrossingStore(database.db()));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store->AddCrossing(db.id, "A", ""));
  ASSERT_OK(store->AddView(MakeView(a.id, 2, 1, 30), {}));
  ViewRecord unheaded = MakeView(a.id, 2, 2, 0);
  unheaded.heading_known = false;
  ASSERT_OK(store->AddView(unheaded, {}));
  ViewRecord replacing = MakeHashedView(0, 3, 0);
  replacing.heading_known = false;
  ASSERT_OK(store->AddViewWithNewCrossing({db.id, "B", ""}, replacing, {}));

  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 3u);
  EXPECT_TRUE(views[0].heading_known);
  EXPECT_EQ(views[0].heading_deg, 30);
  EXPECT_FALSE(views[1].heading_known);
  EXPECT_FALSE(views[2].heading_known);

  ViewReplacement replacement;
  replacement.database_id = db.id;
  replacement.replaced_view_ids = {views[1].id};
  replacement.view = MakeView(a.id, 2, 4, 0);
  replacement.view.heading_known = false;
  ASSERT_OK(store->ReplaceViews(replacement));
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 3u);
  EXPECT_FALSE(views[2].heading_known);
}

// A file a v12 build wrote: its views had headings, and keep them.
TEST(ViewHeadingMigrationTest, VersionTwelveViewsKeepTheirHeadings) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    std::vector<absl::string_view> v12(SchemaMigrations().begin(),
                                       SchemaMigrations().begin() + 12);
    ASSERT_OK(ApplyMigrations(connection, v12));
    ASSERT_OK(connection.Exec(
        "INSERT INTO crossing_db (id, name, params, created_at) VALUES (1, 'city', '{}', 1);"
        "INSERT INTO crossing (id, db_id, name) VALUES (1, 1, 'A');"
        "INSERT INTO view (id, crossing_id, heading_deg, width, height, keypoint_count, "
        "  keypoints, descriptors, hue_hist, hue_bins, format_version, created_at) "
        "  VALUES (1, 1, 0, 320, 240, 0, x'', x'', x'0000803f', 1, 1, 1);"));
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenSqliteCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(1));
  ASSERT_EQ(views.size(), 1u);
  EXPECT_TRUE(views[0].heading_known);
  EXPECT_EQ(views[0].heading_deg, 0);
}

}  // namespace
}  // namespace waymark::storage

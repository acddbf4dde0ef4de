// The retrieval mode's stored global descriptor (schema v7, issue 18): each view's working image
// and the database's vocabulary, loaded as saved, replaced by the next save, deleted with the
// database.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TempDir;

TEST(GlobalDescriptorStoreTest, WorkImageIsStoredAndLoadedWithTheView) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenSqliteCrossingStore(dir.File("waymark.db")));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store->AddCrossing(db.id, "A", ""));
  ViewRecord kept = MakeView(a.id, 2, 1, 30);
  kept.work_image = std::string("\x89PNG\0bytes", 10);
  ASSERT_OK(store->AddView(kept, {}));
  ASSERT_OK(store->AddView(MakeView(a.id, 2, 2, 60), {}));  // none kept
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].work_image, kept.work_image);
  EXPECT_EQ(views[1].work_image, "");
}

TEST(GlobalDescriptorStoreTest, VocabularyIsReplacedAndSurvivesReopening) {
  TempDir dir;
  const std::string path = dir.File("waymark.db");
  int64_t id = 0;
  {
    ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenSqliteCrossingStore(path));
    ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
    id = db.id;
    ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> none, store->LoadVocabulary(id));
    EXPECT_FALSE(none.has_value());
    ASSERT_OK(store->SaveVocabulary({id, 4, std::string("first\0", 6)}));
    ASSERT_OK(store->SaveVocabulary({id, 8, "second"}));
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenSqliteCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> loaded, store->LoadVocabulary(id));
  ASSERT_TRUE(loaded.has_value());
  EXPECT_EQ(loaded->trained_views, 8);
  EXPECT_EQ(loaded->data, "second");
}

TEST(GlobalDescriptorStoreTest, VocabularyOfAnUnknownDatabaseIsRefusedAndGoesWithItsDatabase) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenSqliteCrossingStore(dir.File("waymark.db")));
  EXPECT_EQ(store->SaveVocabulary({999, 1, "x"}).code(), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK(store->SaveVocabulary({db.id, 1, "x"}));
  ASSERT_OK(store->DeleteDatabase("city"));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord again, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> loaded, store->LoadVocabulary(db.id));
  EXPECT_FALSE(loaded.has_value());
  ASSERT_OK_AND_ASSIGN(loaded, store->LoadVocabulary(again.id));
  EXPECT_FALSE(loaded.has_value());
}

}  // namespace
}  // namespace waymark::storage

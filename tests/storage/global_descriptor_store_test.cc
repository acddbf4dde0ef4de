// The retrieval mode's stored global descriptor (schemas v7 and v8, issue 18): each view's working
// image, code and sample, and the database's vocabulary, loaded as saved, replaced by the next
// save, deleted with the database.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TestDatabase;

// One suite, both backends (store_backend.h).
class GlobalDescriptorStoreTest : public ::testing::TestWithParam<testing::Backend> {};
INSTANTIATE_TEST_SUITE_P(Backends, GlobalDescriptorStoreTest, testing::kBothBackends,
                         testing::BackendName);

TEST_P(GlobalDescriptorStoreTest, WorkImageCodeAndSampleAreStoredWithTheView) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenCrossingStore(database.db()));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store->AddCrossing(db.id, "A", ""));
  ViewRecord kept = MakeView(a.id, 2, 1, 30);
  kept.work_image = std::string("\x89PNG\0bytes", 10);
  kept.global_code = std::string("code\0", 5);
  kept.global_sample = "sample";
  ASSERT_OK_AND_ASSIGN(AddViewResult first, store->AddView(kept, {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult second, store->AddView(MakeView(a.id, 2, 2, 60), {}));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(db.id));
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].global_code, kept.global_code);
  EXPECT_EQ(views[0].global_sample, "sample");
  EXPECT_EQ(views[0].work_image, "");  // read back only on demand
  EXPECT_EQ(views[1].global_code, "");
  EXPECT_EQ(views[1].global_sample, "");
  ASSERT_OK_AND_ASSIGN(std::string work, store->LoadWorkImage(first.view_id));
  EXPECT_EQ(work, kept.work_image);
  EXPECT_EQ(store->LoadWorkImage(second.view_id).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store->LoadWorkImage(9999).status().code(), absl::StatusCode::kNotFound);
}

TEST_P(GlobalDescriptorStoreTest, CodesAreSavedWithTheVocabularyForTheDatabasesOwnViewsOnly) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenCrossingStore(database.db()));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord city, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord town, store->CreateDatabase("town", "{}"));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store->AddCrossing(city.id, "A", ""));
  ASSERT_OK_AND_ASSIGN(CrossingRecord b, store->AddCrossing(town.id, "B", ""));
  ASSERT_OK_AND_ASSIGN(AddViewResult mine, store->AddView(MakeView(a.id, 2, 1, 30), {}));
  ASSERT_OK_AND_ASSIGN(AddViewResult theirs, store->AddView(MakeView(b.id, 2, 2, 30), {}));
  // The code for the other database's view and one for a view that is gone are skipped.
  ASSERT_OK(store->SaveVocabulary({city.id, 1, "words"},
                                  {{mine.view_id, "c1"}, {theirs.view_id, "x"}, {9999, "y"}}));
  ASSERT_OK_AND_ASSIGN(std::vector<ViewRecord> views, store->LoadViews(city.id));
  EXPECT_EQ(views[0].global_code, "c1");
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(town.id));
  EXPECT_EQ(views[0].global_code, "");

  ASSERT_OK(store->SaveViewCodes(city.id, {{mine.view_id, "c2"}}));
  ASSERT_OK_AND_ASSIGN(views, store->LoadViews(city.id));
  EXPECT_EQ(views[0].global_code, "c2");
  EXPECT_EQ(store->SaveViewCodes(9999, {}).code(), absl::StatusCode::kNotFound);
}

TEST_P(GlobalDescriptorStoreTest, VocabularyIsReplacedAndSurvivesReopening) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  const std::string path = database.db();
  int64_t id = 0;
  {
    ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenCrossingStore(path));
    ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
    id = db.id;
    ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> none, store->LoadVocabulary(id));
    EXPECT_FALSE(none.has_value());
    ASSERT_OK(store->SaveVocabulary({id, 4, std::string("first\0", 6)}, {}));
    ASSERT_OK(store->SaveVocabulary({id, 8, "second"}, {}));
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> loaded, store->LoadVocabulary(id));
  ASSERT_TRUE(loaded.has_value());
  EXPECT_EQ(loaded->trained_views, 8);
  EXPECT_EQ(loaded->data, "second");
}

TEST_P(GlobalDescriptorStoreTest, VocabularyOfAnUnknownDatabaseIsRefusedAndGoesWithItsDatabase) {
  TestDatabase database(GetParam());
  WAYMARK_SKIP_WITHOUT(database);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store,
                       OpenCrossingStore(database.db()));
  EXPECT_EQ(store->SaveVocabulary({999, 1, "x"}, {}).code(), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store->CreateDatabase("city", "{}"));
  ASSERT_OK(store->SaveVocabulary({db.id, 1, "x"}, {}));
  ASSERT_OK(store->DeleteDatabase("city"));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord again, store->CreateDatabase("city", "{}"));
  ASSERT_OK_AND_ASSIGN(std::optional<VocabularyRecord> loaded, store->LoadVocabulary(db.id));
  EXPECT_FALSE(loaded.has_value());
  ASSERT_OK_AND_ASSIGN(loaded, store->LoadVocabulary(again.id));
  EXPECT_FALSE(loaded.has_value());
}

}  // namespace
}  // namespace waymark::storage

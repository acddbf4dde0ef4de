// What servers sharing a database rely on (issue 19), on both backends: every write adds one to
// the database's revision and the non-appends one to its reload revision; the views after a given
// id; and, on PostgreSQL, the write lock that excludes other servers and the feed that hears them.

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/view_records.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::MakeView;
using ::waymark::storage::testing::TestDatabase;

class DatabaseRevisionTest : public ::testing::TestWithParam<Backend> {
 protected:
  DatabaseRevisionTest() : database_(GetParam()) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    ASSERT_OK_AND_ASSIGN(store_, OpenCrossingStore(database_.db()));
    ASSERT_OK_AND_ASSIGN(DatabaseRecord db, store_->CreateDatabase("city", "{}"));
    db_ = db.id;
  }

  // {revision, reload_revision} as stored.
  std::pair<int64_t, int64_t> Revisions() {
    absl::StatusOr<DatabaseRecord> record = store_->GetDatabase("city");
    EXPECT_TRUE(record.ok()) << record.status();
    return record.ok() ? std::make_pair(record->revision, record->reload_revision)
                       : std::make_pair(int64_t{-1}, int64_t{-1});
  }

  TestDatabase database_;
  std::unique_ptr<CrossingStore> store_;
  int64_t db_ = 0;
};

INSTANTIATE_TEST_SUITE_P(Backends, DatabaseRevisionTest, testing::kBothBackends,
                         testing::BackendName);

TEST_P(DatabaseRevisionTest, EveryWriteAddsOneAndEveryNonAppendAlsoAReload) {
  using Revision = std::pair<int64_t, int64_t>;
  EXPECT_EQ(Revisions(), Revision(0, 0));
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store_->AddCrossing(db_, "A", ""));
  EXPECT_EQ(Revisions(), Revision(1, 0));
  ASSERT_OK_AND_ASSIGN(AddViewResult first, store_->AddView(MakeView(a.id, 3, 1), {}));
  EXPECT_EQ(Revisions(), Revision(2, 0));
  ASSERT_OK_AND_ASSIGN(AddViewResult second,
                       store_->AddViewWithNewCrossing({db_, "B", ""}, MakeView(0, 3, 2), {}));
  EXPECT_EQ(Revisions(), Revision(3, 0));

  ASSERT_OK(store_->ReplaceClusters(db_, {{0, first.view_id, {first.view_id, second.view_id}}}));
  EXPECT_EQ(Revisions(), Revision(4, 1));
  ASSERT_OK(store_->SaveVocabulary({db_, 2, "words"}, {{first.view_id, "code"}}));
  EXPECT_EQ(Revisions(), Revision(5, 2));
  ASSERT_OK(store_->SaveViewCodes(db_, {{second.view_id, "code"}}));
  EXPECT_EQ(Revisions(), Revision(6, 3));
  ASSERT_OK(store_->UpdateDatabaseParams(db_, "{\"x\":1}"));
  EXPECT_EQ(Revisions(), Revision(7, 4));
  ViewReplacement replacement;
  replacement.database_id = db_;
  replacement.replaced_view_ids = {second.view_id};
  replacement.view = MakeView(a.id, 3, 3);
  ASSERT_OK(store_->ReplaceViews(replacement));
  EXPECT_EQ(Revisions(), Revision(8, 5));
  ASSERT_OK(store_->DeleteCrossing(db_, a.id, {}));
  EXPECT_EQ(Revisions(), Revision(9, 6));

  // A failed write changes nothing, its revision included.
  EXPECT_EQ(CodeOf(store_->AddCrossing(db_, "B", "")), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(Revisions(), Revision(9, 6));
}

TEST_P(DatabaseRevisionTest, ViewsAfterAnIdAreTheNewerOnesInOrder) {
  ASSERT_OK_AND_ASSIGN(CrossingRecord a, store_->AddCrossing(db_, "A", ""));
  std::vector<int64_t> ids;
  for (int i = 0; i < 5; ++i) {
    ASSERT_OK_AND_ASSIGN(AddViewResult added, store_->AddView(MakeView(a.id, 2, i), {}));
    ids.push_back(added.view_id);
  }
  std::vector<int64_t> after;
  ASSERT_OK(store_->ForEachViewAfter(db_, ids[1], [&after](ViewRecord&& view) {
    after.push_back(view.id);
    return absl::OkStatus();
  }));
  EXPECT_EQ(after, std::vector<int64_t>(ids.begin() + 2, ids.end()));
  after.clear();
  ASSERT_OK(store_->ForEachViewAfter(db_, ids.back(), [&after](ViewRecord&& view) {
    after.push_back(view.id);
    return absl::OkStatus();
  }));
  EXPECT_TRUE(after.empty());
}

TEST_P(DatabaseRevisionTest, OnlyPostgresIsSharedAndWatched) {
  EXPECT_EQ(store_->shared(), GetParam() == Backend::kPostgres);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ChangeFeed> feed, store_->WatchChanges());
  EXPECT_EQ(feed != nullptr, GetParam() == Backend::kPostgres);
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<DatabaseWriteLock> lock, store_->LockForWriting(db_));
  EXPECT_NE(lock, nullptr);
}

// Two stores stand for two servers on one PostgreSQL database.
class SharedDatabaseTest : public DatabaseRevisionTest {
 protected:
  void SetUp() override {
    DatabaseRevisionTest::SetUp();
    if (IsSkipped() || HasFatalFailure()) return;
    ASSERT_OK_AND_ASSIGN(other_, OpenCrossingStore(database_.db()));
  }

  std::unique_ptr<CrossingStore> other_;
};

INSTANTIATE_TEST_SUITE_P(Postgres, SharedDatabaseTest, ::testing::Values(Backend::kPostgres),
                         testing::BackendName);

TEST_P(SharedDatabaseTest, AWriteLockExcludesEveryOtherHolderUntilReleased) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<DatabaseWriteLock> held, store_->LockForWriting(db_));
  std::atomic<bool> second_held{false};
  std::thread other([&] {
    absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> lock = other_->LockForWriting(db_);
    EXPECT_TRUE(lock.ok()) << lock.status();
    second_held = true;
  });
  // However long the other thread has had, it cannot hold the lock while this one does.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(second_held);
  held.reset();
  other.join();
  EXPECT_TRUE(second_held);
  // Another database's lock is independent.
  ASSERT_OK_AND_ASSIGN(DatabaseRecord town, store_->CreateDatabase("town", "{}"));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<DatabaseWriteLock> mine, store_->LockForWriting(db_));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<DatabaseWriteLock> theirs, other_->LockForWriting(town.id));
}

TEST_P(SharedDatabaseTest, TheFeedHearsTheOtherServersWritesOnce) {
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ChangeFeed> feed, store_->WatchChanges());
  ASSERT_NE(feed, nullptr);
  ASSERT_OK(other_->AddCrossing(db_, "A", ""));
  bool heard = false;
  // Bounded only so that a broken feed ends the test; a working one answers at once.
  for (int i = 0; i < 100 && !heard; ++i) {
    ASSERT_OK_AND_ASSIGN(heard, feed->Wait(100));
  }
  EXPECT_TRUE(heard);
  ASSERT_OK_AND_ASSIGN(bool again, feed->Wait(0));
  EXPECT_FALSE(again);  // consumed
  // A failed write sends nothing.
  EXPECT_FALSE(other_->AddCrossing(db_, "A", "").ok());
  ASSERT_OK_AND_ASSIGN(again, feed->Wait(200));
  EXPECT_FALSE(again);
}

}  // namespace
}  // namespace waymark::storage

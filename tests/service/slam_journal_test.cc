// The SLAM journal (issue 21): accepted messages are stored before they are processed, in one
// transaction for whatever piled up meanwhile; a message that cannot be stored is refused, not
// processed.

#include "server/service/slam/slam_journal.h"

#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/slam/slam_registry.h"
#include "storage/slam_store.h"
#include "tests/service/faulty_slam_store.h"
#include "tests/service/slam_answers.h"
#include "tests/service/slam_test_world.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::service {
namespace {

using ::waymark::storage::testing::TempDir;
using ::waymark::testing::Odom;
using ::waymark::testing::RoomScan;
using ::waymark::testing::TestSessionRequest;

storage::SlamJournalEntry Entry(int64_t seq) {
  return storage::SlamJournalEntry{"s", seq, "message " + std::to_string(seq)};
}

class SlamJournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto real = storage::OpenSqliteSlamStore(dir_.File("slam.db"));
    ASSERT_TRUE(real.ok()) << real.status();
    store_ = std::make_unique<FaultySlamStore>(*std::move(real));
    storage::SlamSessionRecord session;
    session.id = "s";
    session.robot_id = "r";
    ASSERT_OK(store_->CreateSession(session).status());
  }

  TempDir dir_;
  std::unique_ptr<FaultySlamStore> store_;
};

TEST_F(SlamJournalTest, WhatIsAppendedDuringAWriteIsStoredInTheNextTransactionTogether) {
  SlamJournal journal(store_.get(), nullptr);
  store_->Hold();
  const uint64_t first = journal.Append(Entry(1));
  store_->WaitHeld();  // the writer is in its first transaction
  uint64_t last = first;
  for (int64_t seq = 2; seq <= 11; ++seq) last = journal.Append(Entry(seq));
  store_->Release();
  EXPECT_OK(journal.WaitStored(last));
  EXPECT_OK(journal.WaitStored(first));
  EXPECT_EQ(store_->batches(), (std::vector<size_t>{1, 10}));
  ASSERT_OK_AND_ASSIGN(auto stored, store_->LoadJournal("s"));
  ASSERT_EQ(stored.size(), 11u);
  EXPECT_EQ(stored[10].message, "message 11");
  const SlamJournalStats stats = journal.stats();
  EXPECT_EQ(stats.batches, 2u);
  EXPECT_EQ(stats.messages, 11u);
  EXPECT_EQ(stats.failed_batches, 0u);
}

TEST_F(SlamJournalTest, AFailingWriteIsRetriedAndAfterTheLastAttemptItsMessagesGetTheError) {
  SlamJournalOptions options;
  options.attempts = 3;
  options.retry_seconds = 0.001;
  SlamJournal journal(store_.get(), nullptr, options);
  // Two failures, then the third attempt lands.
  store_->FailJournal(2, absl::UnavailableError("database is locked"));
  EXPECT_OK(journal.WaitStored(journal.Append(Entry(1))));
  EXPECT_EQ(store_->batches(), (std::vector<size_t>{1, 1, 1}));

  store_->FailJournal(-1, absl::InternalError("disk I/O error"));
  const absl::Status refused = journal.WaitStored(journal.Append(Entry(2)));
  EXPECT_EQ(refused.code(), absl::StatusCode::kInternal);
  EXPECT_NE(refused.message().find("could not be stored (disk I/O error)"), std::string::npos)
      << refused;
  EXPECT_EQ(journal.stats().failed_batches, 1u);

  store_->FailJournal(0, absl::OkStatus());
  EXPECT_OK(journal.WaitStored(journal.Append(Entry(3))));
  ASSERT_OK_AND_ASSIGN(auto stored, store_->LoadJournal("s"));
  ASSERT_EQ(stored.size(), 2u);
  EXPECT_EQ(stored[1].seq, 3);
}

TEST_F(SlamJournalTest, StopWritesWhatIsQueuedAndRefusesLaterMessages) {
  SlamJournal journal(store_.get(), nullptr);
  store_->Hold();
  const uint64_t queued = journal.Append(Entry(1));
  store_->WaitHeld();
  const uint64_t behind = journal.Append(Entry(2));
  store_->Release();
  journal.Stop();
  EXPECT_OK(journal.WaitStored(queued));
  EXPECT_OK(journal.WaitStored(behind));
  EXPECT_EQ(journal.WaitStored(journal.Append(Entry(3))).code(), absl::StatusCode::kUnavailable);
  ASSERT_OK_AND_ASSIGN(auto stored, store_->LoadJournal("s"));
  EXPECT_EQ(stored.size(), 2u);
}

TEST_F(SlamJournalTest, TheRegistryRefusesAScanItCannotStoreAndDoesNotProcessIt) {
  FaultySlamStore* faults = store_.get();
  SlamRegistryOptions options;
  options.workers = 2;
  auto registry = SlamRegistry::Create(std::move(store_), options);
  ASSERT_TRUE(registry.ok()) << registry.status();
  ASSERT_OK_AND_ASSIGN(v1::Session session, (*registry)->CreateSession(TestSessionRequest("r")));
  Answers answers;
  {
    ASSERT_OK_AND_ASSIGN(auto stream,
                         (*registry)->OpenStream(session.session_id(), answers.Sink()));
    faults->FailJournal(-1, absl::InternalError("disk I/O error"));
    ASSERT_OK(stream->Submit(Odom(1, 1.0, 0, 0, 0)));
    ASSERT_OK(stream->Submit(RoomScan(2, 1.0, 0, 0, 0)));
    stream->Close();  // waits for the answers
    faults->FailJournal(0, absl::OkStatus());
  }
  std::vector<v1::SlamUpdate> got = answers.Get();
  ASSERT_EQ(got.size(), 2u);  // the odometry's refusal and the scan's
  for (const v1::SlamUpdate& update : got) {
    ASSERT_TRUE(update.has_rejection()) << update.DebugString();
    EXPECT_EQ(update.rejection().code(), static_cast<int>(absl::StatusCode::kInternal));
    EXPECT_NE(update.rejection().message().find("could not be stored"), std::string::npos);
  }
  ASSERT_OK_AND_ASSIGN(v1::Session described, (*registry)->GetSession(session.session_id()));
  EXPECT_EQ(described.scans_processed(), 0u);

  // Once the database takes writes again, the session goes on.
  Answers later;
  ASSERT_OK_AND_ASSIGN(auto stream, (*registry)->OpenStream(session.session_id(), later.Sink()));
  ASSERT_OK(stream->Submit(Odom(3, 2.0, 0.1, 0, 0)));
  ASSERT_OK(stream->Submit(RoomScan(4, 2.0, 0.1, 0, 0)));
  stream->Close();
  ASSERT_EQ(later.Get().size(), 1u);
  EXPECT_FALSE(later.Get()[0].has_rejection()) << later.Get()[0].rejection().message();
  ASSERT_OK_AND_ASSIGN(described, (*registry)->GetSession(session.session_id()));
  EXPECT_EQ(described.scans_processed(), 1u);
}

}  // namespace
}  // namespace waymark::service

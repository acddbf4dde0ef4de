// A SLAM session leaves memory when it is closed or deleted (issue 38: closing 20 robots'
// sessions gave back 23 of 196 MB): its state and engine are destroyed once the last holder (the
// session table, a stream still ending, a reader) lets go, the registry's observers hear of it
// exactly once, and what the metrics kept for it goes without a scrape. Counts of live objects,
// not resident memory, so nothing here depends on the allocator.
//
// The last holder may be a worker that has just answered the session's last message and lets go
// of it a moment after the close returned: the release is awaited (Eventually), then counted.

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/operations/metrics.h"
#include "server/service/slam/slam_registry.h"
#include "storage/slam_store.h"
#include "tests/service/slam_test_world.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::service {
namespace {

using ::waymark::storage::testing::TempDir;
using ::waymark::testing::Odom;
using ::waymark::testing::RoomScan;
using ::waymark::testing::TestSessionRequest;

// Waits until `done` holds (a generous bound for a loaded machine, not a timing assertion).
bool Eventually(const std::function<bool()>& done) {
  for (int i = 0; i < 30000; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

// The sessions the registry said left memory, and how often each.
class Releases {
 public:
  SlamObserver Observer() {
    SlamObserver observer;
    observer.on_released = [this](const std::string& id) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++count_[id];
    };
    return observer;
  }
  int Of(const std::string& id) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = count_.find(id);
    return it == count_.end() ? 0 : it->second;
  }
  // Waits until `id` was released `times` times, then says how often it was.
  int Await(const std::string& id, int times) {
    Eventually([&] { return Of(id) >= times; });
    return Of(id);
  }
  int Total() {
    std::lock_guard<std::mutex> lock(mutex_);
    int total = 0;
    for (const auto& [id, n] : count_) total += n;
    return total;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, int> count_;
};

class SessionMemoryTest : public ::testing::Test {
 protected:
  std::unique_ptr<SlamRegistry> MakeRegistry() {
    SlamRegistryOptions options;
    options.workers = 2;
    auto store = storage::OpenSqliteSlamStore(dir_.File("slam.db"));
    EXPECT_TRUE(store.ok()) << store.status();
    auto registry = SlamRegistry::Create(std::move(*store), options);
    EXPECT_TRUE(registry.ok()) << registry.status();
    return std::move(*registry);
  }

  // A new session that has processed `scans` scans (its stream closed: every one answered).
  static std::string SessionWithScans(SlamRegistry& registry, const std::string& robot,
                                      int scans) {
    absl::StatusOr<v1::Session> session = registry.CreateSession(TestSessionRequest(robot));
    EXPECT_TRUE(session.ok()) << session.status();
    absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> stream =
        registry.OpenStream(session->session_id(), [](const v1::SlamUpdate&) {});
    EXPECT_TRUE(stream.ok()) << stream.status();
    Drive(**stream, scans);
    (*stream)->Close();
    return session->session_id();
  }

  static void Drive(SlamRegistry::Stream& stream, int scans) {
    for (int k = 0; k < scans; ++k) {
      const double x = 0.1 * k, t = 1.0 + k;
      EXPECT_TRUE(stream.Submit(Odom(2 * k + 1, t, x, 0, 0)).ok());
      EXPECT_TRUE(stream.Submit(RoomScan(2 * k + 2, t, x, 0, 0)).ok());
    }
  }

  static int Resident(SlamRegistry& registry) {
    absl::StatusOr<v1::ListSessionsResponse> listed = registry.ListSessions("");
    EXPECT_TRUE(listed.ok()) << listed.status();
    int resident = 0;
    for (const v1::Session& session : listed->sessions()) resident += session.resident() ? 1 : 0;
    return resident;
  }

  TempDir dir_;
  std::unique_ptr<Releases> staying_ = std::make_unique<Releases>();
};

TEST_F(SessionMemoryTest, ClosingEverySessionReleasesEachOnce) {
  Releases releases;  // outlives the registry, which calls it
  auto registry = MakeRegistry();
  registry->AddObserver(releases.Observer());
  std::vector<std::string> ids;
  for (int robot = 0; robot < 3; ++robot) {
    ids.push_back(SessionWithScans(*registry, "r" + std::to_string(robot), 12));
  }
  EXPECT_EQ(Resident(*registry), 3);
  EXPECT_EQ(releases.Total(), 0) << "released while still open";

  for (const std::string& id : ids) ASSERT_TRUE(registry->CloseSession(id).ok()) << id;
  for (const std::string& id : ids) EXPECT_EQ(releases.Await(id, 1), 1) << id;
  EXPECT_EQ(Resident(*registry), 0);
}

TEST_F(SessionMemoryTest, AStreamStillEndingHoldsTheSessionUntilItGoes) {
  Releases releases;  // outlives the registry, which calls it
  auto registry = MakeRegistry();
  registry->AddObserver(releases.Observer());
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  const std::string id = session.session_id();
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<SlamRegistry::Stream> stream,
                       registry->OpenStream(id, [](const v1::SlamUpdate&) {}));
  Drive(*stream, 5);
  stream->Close();  // detached: the session may close, but the stream object still holds it

  ASSERT_TRUE(registry->CloseSession(id).ok());
  EXPECT_EQ(Resident(*registry), 0);
  EXPECT_EQ(releases.Of(id), 0);
  stream.reset();
  EXPECT_EQ(releases.Await(id, 1), 1);
}

TEST_F(SessionMemoryTest, DeletingAndReadingAClosedSessionReleaseToo) {
  Releases releases;  // outlives the registry, which calls it
  auto registry = MakeRegistry();
  registry->AddObserver(releases.Observer());
  const std::string deleted = SessionWithScans(*registry, "r1", 6);
  const std::string closed = SessionWithScans(*registry, "r2", 6);

  ASSERT_TRUE(registry->DeleteSession(deleted, /*force=*/true).ok());  // closes it first
  EXPECT_EQ(releases.Await(deleted, 1), 1);

  ASSERT_TRUE(registry->CloseSession(closed).ok());
  EXPECT_EQ(releases.Await(closed, 1), 1);
  // Reading a closed session rebuilds it from the store for the call only (the caller's thread
  // holds it alone: released when the call returns).
  ASSERT_TRUE(registry->GetMap(closed).ok());
  EXPECT_EQ(releases.Of(closed), 2);
  ASSERT_TRUE(registry->GetTrajectory(closed).ok());
  EXPECT_EQ(releases.Of(closed), 3);
  EXPECT_EQ(Resident(*registry), 0);
}

TEST_F(SessionMemoryTest, ARemovedObserverHearsNothingMore) {
  Releases releases;  // outlives the registry, which calls it
  auto registry = MakeRegistry();
  const uint64_t observer = registry->AddObserver(releases.Observer());
  const std::string first = SessionWithScans(*registry, "r1", 3);
  const std::string second = SessionWithScans(*registry, "r2", 3);
  ASSERT_TRUE(registry->CloseSession(first).ok());
  EXPECT_EQ(releases.Await(first, 1), 1);
  registry->RemoveObserver(observer);
  ASSERT_TRUE(registry->CloseSession(second).ok());
  // Its release is awaited through another observer that stays.
  Releases& staying = *staying_;
  registry->AddObserver(staying.Observer());
  const std::string third = SessionWithScans(*registry, "r3", 3);
  ASSERT_TRUE(registry->CloseSession(third).ok());
  EXPECT_EQ(staying.Await(third, 1), 1);
  EXPECT_EQ(releases.Of(second), 0);
  EXPECT_EQ(releases.Of(third), 0);
}

TEST_F(SessionMemoryTest, MetricsDropASessionsEntryWhenItLeavesMemoryWithoutAScrape) {
  auto registry = MakeRegistry();
  MetricsSources sources;
  sources.slam = registry.get();
  auto metrics = std::make_unique<Metrics>(sources);  // no endpoint: nobody scrapes
  std::vector<std::string> ids;
  for (int robot = 0; robot < 3; ++robot) {
    ids.push_back(SessionWithScans(*registry, "r" + std::to_string(robot), 4));
  }
  EXPECT_EQ(metrics->slam_sessions_tracked(), 3u);
  ASSERT_TRUE(registry->CloseSession(ids[0]).ok());
  Eventually([&] { return metrics->slam_sessions_tracked() < 3; });
  EXPECT_EQ(metrics->slam_sessions_tracked(), 2u);
  ASSERT_TRUE(registry->DeleteSession(ids[1], /*force=*/true).ok());
  ASSERT_TRUE(registry->CloseSession(ids[2]).ok());
  Eventually([&] { return metrics->slam_sessions_tracked() == 0; });
  EXPECT_EQ(metrics->slam_sessions_tracked(), 0u);
  metrics.reset();  // before the registry it reads
}

}  // namespace
}  // namespace waymark::service

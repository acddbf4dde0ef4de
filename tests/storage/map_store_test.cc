// The MapStore (issue 38) on both backends: maps created, listed, read and deleted, trajectories
// joining in order, the first one anchoring the map frame, ties, sessions leaving (deleted with
// their session, or removed), the name rules and the errors, and a reopened database.

#include "storage/map_store.h"

#include <chrono>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "storage/map_records.h"
#include "storage/open_stores.h"
#include "storage/slam_store.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TestDatabase;

class MapStoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  MapStoreTest() : database_(GetParam()) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    ASSERT_OK_AND_ASSIGN(maps_, OpenMapStore(database_.db()));
    ASSERT_OK_AND_ASSIGN(sessions_, OpenSlamStore(database_.db()));
  }

  void AddSession(const std::string& id, const std::string& robot) {
    SlamSessionRecord session;
    session.id = id;
    session.robot_id = robot;
    ASSERT_OK(sessions_->CreateSession(session));
  }

  TestDatabase database_;
  std::unique_ptr<MapStore> maps_;
  std::unique_ptr<SlamStore> sessions_;
};

INSTANTIATE_TEST_SUITE_P(Backends, MapStoreTest, testing::kBothBackends, testing::BackendName);

TEST_P(MapStoreTest, CreatesListsAndReadsMaps) {
  ASSERT_OK_AND_ASSIGN(MapRecord office, maps_->CreateMap("office"));
  EXPECT_EQ(office.name, "office");
  EXPECT_EQ(office.revision, 0);
  EXPECT_GT(office.created_at, 0);
  EXPECT_TRUE(office.trajectories.empty());
  ASSERT_OK(maps_->CreateMap("Building-2.floor_1"));
  EXPECT_EQ(CodeOf(maps_->CreateMap("office")), absl::StatusCode::kAlreadyExists);

  ASSERT_OK_AND_ASSIGN(std::vector<MapRecord> listed, maps_->ListMaps());
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].name, "Building-2.floor_1");  // byte order: upper case first
  EXPECT_EQ(listed[1].name, "office");
  ASSERT_OK_AND_ASSIGN(MapRecord got, maps_->GetMap("office"));
  EXPECT_DOUBLE_EQ(got.created_at, office.created_at);
  EXPECT_EQ(CodeOf(maps_->GetMap("cellar")), absl::StatusCode::kNotFound);
}

TEST_P(MapStoreTest, RefusesBadNamesWithoutEchoingThem) {
  for (const std::string& bad :
       {std::string(), std::string(65, 'a'), std::string("a/b"), std::string("-lead"),
        std::string(".hidden"), std::string("sp ace"), std::string("nul\0x", 5),
        std::string("caf\xc3\xa9")}) {
    const absl::StatusOr<MapRecord> created = maps_->CreateMap(bad);
    EXPECT_EQ(CodeOf(created), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(created.status().message().find("map name"), std::string::npos);
    if (bad.size() > 2) {
      EXPECT_EQ(created.status().message().find(bad), std::string::npos) << bad;
    }
    EXPECT_EQ(CodeOf(maps_->GetMap(bad)), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(CodeOf(maps_->DeleteMap(bad)), absl::StatusCode::kInvalidArgument);
  }
  EXPECT_OK(maps_->CreateMap(std::string(64, 'a')));
  EXPECT_OK(maps_->CreateMap("7"));
}

TEST_P(MapStoreTest, TheFirstTrajectoryDefinesTheMapFrameTheOthersWait) {
  AddSession("s1", "robot-1");
  AddSession("s2", "robot-2");
  AddSession("s3", "robot-1");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK_AND_ASSIGN(MapRecord one, maps_->AddTrajectory("office", "s1"));
  EXPECT_EQ(one.revision, 1);
  ASSERT_EQ(one.trajectories.size(), 1u);
  EXPECT_EQ(one.trajectories[0].session_id, "s1");
  EXPECT_EQ(one.trajectories[0].robot_id, "robot-1");
  EXPECT_EQ(one.trajectories[0].ordinal, 1);
  EXPECT_EQ(one.trajectories[0].session_state, SlamSessionState::kOpen);
  ASSERT_TRUE(one.trajectories[0].tie.has_value());
  EXPECT_EQ(one.trajectories[0].tie->x, 0);
  EXPECT_EQ(one.trajectories[0].tie->theta, 0);

  ASSERT_OK(maps_->AddTrajectory("office", "s2"));
  ASSERT_OK_AND_ASSIGN(MapRecord three, maps_->AddTrajectory("office", "s3"));
  EXPECT_EQ(three.revision, 3);
  ASSERT_EQ(three.trajectories.size(), 3u);
  EXPECT_EQ(three.trajectories[1].session_id, "s2");
  EXPECT_EQ(three.trajectories[1].robot_id, "robot-2");
  EXPECT_FALSE(three.trajectories[1].tie.has_value());  // not yet in the map
  EXPECT_EQ(three.trajectories[2].ordinal, 3);
  EXPECT_FALSE(three.trajectories[2].tie.has_value());

  // What ties a robot in (the next slice) stores where its frame lies in the map frame.
  ASSERT_OK_AND_ASSIGN(MapRecord tied, maps_->TieTrajectory("office", "s2", MapTie{1.5, -2, 0.25}, ""));
  EXPECT_EQ(tied.revision, 4);
  ASSERT_TRUE(tied.trajectories[1].tie.has_value());
  EXPECT_DOUBLE_EQ(tied.trajectories[1].tie->x, 1.5);
  EXPECT_DOUBLE_EQ(tied.trajectories[1].tie->y, -2);
  EXPECT_DOUBLE_EQ(tied.trajectories[1].tie->theta, 0.25);
  EXPECT_EQ(CodeOf(maps_->TieTrajectory("office", "nobody", MapTie{}, "")),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(maps_->TieTrajectory(
                "office", "s3", MapTie{std::numeric_limits<double>::quiet_NaN(), 0, 0}, "")),
            absl::StatusCode::kInvalidArgument);
}

TEST_P(MapStoreTest, ASessionJoinsOneMapOnce) {
  AddSession("s1", "robot-1");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->CreateMap("lab"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  const absl::StatusOr<MapRecord> again = maps_->AddTrajectory("office", "s1");
  EXPECT_EQ(CodeOf(again), absl::StatusCode::kAlreadyExists);
  const absl::StatusOr<MapRecord> other = maps_->AddTrajectory("lab", "s1");
  EXPECT_EQ(CodeOf(other), absl::StatusCode::kAlreadyExists);
  EXPECT_NE(other.status().message().find("\"office\""), std::string::npos)
      << other.status().message();
  EXPECT_EQ(CodeOf(maps_->AddTrajectory("office", "missing")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(maps_->AddTrajectory("cellar", "s1")), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(MapRecord office, maps_->GetMap("office"));
  EXPECT_EQ(office.revision, 1);  // the refusals changed nothing
  EXPECT_EQ(office.trajectories.size(), 1u);
}

TEST_P(MapStoreTest, ADeletedSessionLeavesItsMapAndTheNextOldestAnchorsIt) {
  AddSession("s1", "robot-1");
  AddSession("s2", "robot-2");
  AddSession("s3", "robot-3");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  ASSERT_OK(maps_->AddTrajectory("office", "s2"));
  ASSERT_OK(maps_->AddTrajectory("office", "s3"));
  // Deleting the session removes its trajectory row with it (a cascade) ...
  ASSERT_OK(sessions_->DeleteSession("s1"));
  ASSERT_OK_AND_ASSIGN(MapRecord cascaded, maps_->GetMap("office"));
  ASSERT_EQ(cascaded.trajectories.size(), 2u);
  EXPECT_EQ(cascaded.trajectories[0].session_id, "s2");
  // ... and RemoveTrajectory counts the change and gives the map a frame again.
  ASSERT_OK_AND_ASSIGN(MapRecord removed, maps_->RemoveTrajectory("office", "s1"));
  EXPECT_EQ(removed.revision, 4);
  ASSERT_EQ(removed.trajectories.size(), 2u);
  ASSERT_TRUE(removed.trajectories[0].tie.has_value());
  EXPECT_FALSE(removed.trajectories[1].tie.has_value());
  // A session still there is removed by the call itself.
  ASSERT_OK_AND_ASSIGN(MapRecord again, maps_->RemoveTrajectory("office", "s3"));
  EXPECT_EQ(again.trajectories.size(), 1u);
  EXPECT_EQ(again.revision, 5);
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord s3, sessions_->GetSession("s3"));
  EXPECT_EQ(s3.robot_id, "robot-3");  // the session itself stays
  EXPECT_EQ(CodeOf(maps_->RemoveTrajectory("cellar", "s3")), absl::StatusCode::kNotFound);
}

TEST_P(MapStoreTest, DeletingAMapKeepsItsSessions) {
  AddSession("s1", "robot-1");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  ASSERT_OK_AND_ASSIGN(MapRecord deleted, maps_->DeleteMap("office"));
  EXPECT_EQ(deleted.trajectories.size(), 1u);  // as it was
  EXPECT_EQ(CodeOf(maps_->GetMap("office")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(maps_->DeleteMap("office")), absl::StatusCode::kNotFound);
  EXPECT_OK(sessions_->GetSession("s1"));
  ASSERT_OK_AND_ASSIGN(int64_t rows, database_.CountRows("slam_map_trajectory"));
  EXPECT_EQ(rows, 0);
  // The session is free to join another map, and the name to be used again.
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK_AND_ASSIGN(MapRecord rejoined, maps_->AddTrajectory("office", "s1"));
  EXPECT_EQ(rejoined.revision, 1);
}

TEST_P(MapStoreTest, ClosedSessionsShowAsClosedAndEverythingSurvivesReopening) {
  AddSession("s1", "robot-1");
  AddSession("s2", "robot-2");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  ASSERT_OK(maps_->AddTrajectory("office", "s2"));
  SlamCheckpoint final_checkpoint;
  final_checkpoint.scans_processed = 42;
  ASSERT_OK(sessions_->CloseSession("s1", final_checkpoint));
  maps_.reset();
  ASSERT_OK_AND_ASSIGN(maps_, OpenMapStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(std::vector<MapRecord> listed, maps_->ListMaps());
  ASSERT_EQ(listed.size(), 1u);
  const MapRecord& office = listed[0];
  EXPECT_EQ(office.revision, 2);
  ASSERT_EQ(office.trajectories.size(), 2u);
  EXPECT_EQ(office.trajectories[0].session_state, SlamSessionState::kClosed);
  EXPECT_EQ(office.trajectories[0].scans_processed, 42);
  EXPECT_TRUE(office.trajectories[0].tie.has_value());
  EXPECT_EQ(office.trajectories[1].session_state, SlamSessionState::kOpen);
  EXPECT_FALSE(office.trajectories[1].tie.has_value());
}

TEST_P(MapStoreTest, AFollowIsStoredWithItsTieAndANewTieStartsWithout) {
  AddSession("s1", "robot-1");
  AddSession("s2", "robot-2");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  ASSERT_OK(maps_->AddTrajectory("office", "s2"));
  // Any bytes (the service's encoding), zeros included.
  const std::string follow("samples\0\x01\xff of s2", 17);
  ASSERT_OK_AND_ASSIGN(MapRecord followed,
                       maps_->TieTrajectory("office", "s2", MapTie{1, 2, 0.5}, follow));
  EXPECT_EQ(followed.trajectories[1].follow, follow);
  EXPECT_TRUE(followed.trajectories[0].follow.empty());
  ASSERT_OK_AND_ASSIGN(std::vector<MapRecord> listed, maps_->ListMaps());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].trajectories[1].follow, follow);
  // It survives reopening the database (a restart).
  ASSERT_OK_AND_ASSIGN(maps_, OpenMapStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(MapRecord reopened, maps_->GetMap("office"));
  EXPECT_EQ(reopened.trajectories[1].follow, follow);
  ASSERT_TRUE(reopened.trajectories[1].tie.has_value());
  EXPECT_DOUBLE_EQ(reopened.trajectories[1].tie->theta, 0.5);
  ASSERT_OK_AND_ASSIGN(MapRecord tied_again,
                       maps_->TieTrajectory("office", "s2", MapTie{3, 4, 0}, ""));
  EXPECT_TRUE(tied_again.trajectories[1].follow.empty());
}

TEST_P(MapStoreTest, OneServerAtATimeHoldsAMapsLease) {
  AddSession("s1", "robot-1");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK_AND_ASSIGN(MapRecord joined, maps_->AddTrajectory("office", "s1"));
  EXPECT_TRUE(joined.lease.owner.empty());
  // A second server: its own connection to the same database.
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<MapStore> other, OpenMapStore(database_.db()));

  ASSERT_OK_AND_ASSIGN(SlamLease a, maps_->AcquireMapLease("office", "server-a", "a:1", 60));
  EXPECT_EQ(a.owner, "server-a");
  EXPECT_EQ(a.address, "a:1");
  ASSERT_OK_AND_ASSIGN(SlamLease refused, other->AcquireMapLease("office", "server-b", "b:1", 60));
  EXPECT_EQ(refused.owner, "server-a");  // held: the holder comes back, nothing changed
  EXPECT_EQ(refused.address, "a:1");
  ASSERT_OK_AND_ASSIGN(SlamLease renewed, maps_->AcquireMapLease("office", "server-a", "a:1", 60));
  EXPECT_EQ(renewed.owner, "server-a");
  EXPECT_GE(renewed.expires_at, a.expires_at);
  ASSERT_OK_AND_ASSIGN(MapRecord read, other->GetMap("office"));
  EXPECT_EQ(read.lease.owner, "server-a");
  EXPECT_EQ(read.revision, joined.revision);  // who works on a map is not what it holds

  // Given up by a server that does not hold it: nothing happens.
  ASSERT_OK(other->ReleaseMapLease("office", "server-b"));
  ASSERT_OK_AND_ASSIGN(read, other->GetMap("office"));
  EXPECT_EQ(read.lease.owner, "server-a");
  // Given up by its holder: the next server takes it at once.
  ASSERT_OK(maps_->ReleaseMapLease("office", "server-a"));
  ASSERT_OK_AND_ASSIGN(SlamLease b, other->AcquireMapLease("office", "server-b", "b:1", 0.05));
  EXPECT_EQ(b.owner, "server-b");
  // Not renewed: once expired, another server takes it over.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_OK_AND_ASSIGN(SlamLease taken, maps_->AcquireMapLease("office", "server-a", "a:1", 60));
  EXPECT_EQ(taken.owner, "server-a");

  EXPECT_EQ(CodeOf(maps_->AcquireMapLease("nowhere", "server-a", "a:1", 60)),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(maps_->AcquireMapLease("office", "", "a:1", 60)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(maps_->AcquireMapLease("office", "server-a", "a:1", 0)),
            absl::StatusCode::kInvalidArgument);
}

TEST_P(MapStoreTest, ATieStoredInPartIsDataLoss) {
  AddSession("s1", "robot-1");
  ASSERT_OK(maps_->CreateMap("office"));
  ASSERT_OK(maps_->AddTrajectory("office", "s1"));
  ASSERT_OK(database_.Exec("UPDATE slam_map_trajectory SET tie_y = NULL"));
  EXPECT_EQ(CodeOf(maps_->GetMap("office")), absl::StatusCode::kDataLoss);
  EXPECT_EQ(CodeOf(maps_->ListMaps()), absl::StatusCode::kDataLoss);
}

// The node feed (a fleet's map owner reads a robot on another server between its checkpoints):
// versions count the publishes, points are read by scan, pruned nodes and a new publisher's
// replace take rows away, and the feed goes with its session.
TEST_P(MapStoreTest, AFeedIsPublishedInPartsAndReadFromAScanOn) {
  AddSession("s1", "r1");
  EXPECT_EQ(CodeOf(maps_->PublishTrajectoryFeed("nobody", TrajectoryFeedUpdate{})),
            absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(std::optional<TrajectoryFeed> none, maps_->ReadTrajectoryFeed("s1", 0, 0));
  EXPECT_FALSE(none.has_value());

  TrajectoryFeedUpdate first;
  first.scans_processed = 12;
  first.poses = std::string("poses\0one", 9);
  first.added = {{3, "three"}, {7, std::string("sev\0en", 6)}};
  ASSERT_OK_AND_ASSIGN(int64_t v1, maps_->PublishTrajectoryFeed("s1", first));
  EXPECT_EQ(v1, 1);
  ASSERT_OK_AND_ASSIGN(std::optional<TrajectoryFeed> all, maps_->ReadTrajectoryFeed("s1", 0, 0));
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(all->version, 1);
  EXPECT_EQ(all->scans_processed, 12);
  EXPECT_EQ(all->poses, first.poses);
  ASSERT_EQ(all->points.size(), 2u);
  EXPECT_EQ(all->points[0].scan, 3);
  EXPECT_EQ(all->points[0].points, "three");
  EXPECT_EQ(all->points[1].points, std::string("sev\0en", 6));
  // Nothing newer than what the reader has.
  ASSERT_OK_AND_ASSIGN(none, maps_->ReadTrajectoryFeed("s1", 1, 0));
  EXPECT_FALSE(none.has_value());

  TrajectoryFeedUpdate second;
  second.scans_processed = 20;
  second.poses = "poses two";
  second.added = {{11, "eleven"}};
  second.dropped = {3};
  ASSERT_OK_AND_ASSIGN(int64_t v2, maps_->PublishTrajectoryFeed("s1", second));
  EXPECT_EQ(v2, 2);
  ASSERT_OK_AND_ASSIGN(std::optional<TrajectoryFeed> newer,
                       maps_->ReadTrajectoryFeed("s1", 1, 7));
  ASSERT_TRUE(newer.has_value());
  EXPECT_EQ(newer->poses, "poses two");
  ASSERT_EQ(newer->points.size(), 1u);  // only the scans after 7
  EXPECT_EQ(newer->points[0].scan, 11);
  ASSERT_OK_AND_ASSIGN(all, maps_->ReadTrajectoryFeed("s1", 0, 0));
  ASSERT_EQ(all->points.size(), 2u);  // 3 was pruned
  EXPECT_EQ(all->points[0].scan, 7);

  // Another server's first publish replaces every row of points.
  TrajectoryFeedUpdate moved;
  moved.scans_processed = 25;
  moved.poses = "poses three";
  moved.added = {{11, "eleven"}, {15, "fifteen"}};
  moved.replace = true;
  ASSERT_OK_AND_ASSIGN(int64_t v3, maps_->PublishTrajectoryFeed("s1", moved));
  EXPECT_EQ(v3, 3);
  ASSERT_OK_AND_ASSIGN(all, maps_->ReadTrajectoryFeed("s1", 0, 0));
  ASSERT_EQ(all->points.size(), 2u);
  EXPECT_EQ(all->points[0].scan, 11);
  EXPECT_EQ(all->points[1].scan, 15);

  // The session deleted: its feed goes with it.
  ASSERT_OK(sessions_->DeleteSession("s1"));
  ASSERT_OK_AND_ASSIGN(none, maps_->ReadTrajectoryFeed("s1", 0, 0));
  EXPECT_FALSE(none.has_value());
}

}  // namespace
}  // namespace waymark::storage

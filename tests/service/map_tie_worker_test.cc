// MapTieWorker (issue 38, server/service/slam/map_tie_worker.h) on its own, its sources faked:
// a map of one robot tied in away from the origin and a second robot joined with no start pose,
// in the synthetic office of the engine's tests. The worker must find the second robot, tie it in
// once at the truth, and ask nothing more of a map with no robot left to find. The real server
// on a real log: tests/integration/map_tie_test.cc.

#include "server/service/slam/map_tie_worker.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <mutex>
#include <string>
#include <vector>

#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::service {
namespace {

namespace ls = waymark::laser_slam;
using ls::testing::Box;
using ls::testing::Wall;

using ls::testing::PillarOffice;

// A robot's nodes every 0.25 m along the polyline, in its own frame (its start).
std::vector<ls::NodeView> Drive(const std::vector<Wall>& walls,
                                const std::vector<Eigen::Vector2d>& corners, ls::Pose2* start) {
  std::vector<ls::NodeView> nodes;
  for (size_t leg = 0; leg + 1 < corners.size(); ++leg) {
    const Eigen::Vector2d d = corners[leg + 1] - corners[leg];
    const int steps = static_cast<int>(d.norm() / 0.25);
    for (int i = 0; i < steps; ++i) {
      const Eigen::Vector2d p = corners[leg] + d * (static_cast<double>(i) / steps);
      const ls::Pose2 truth{p.x(), p.y(), std::atan2(d.y(), d.x())};
      if (nodes.empty()) *start = truth;
      ls::NodeView node;
      node.scan = 3 * nodes.size() + 1;
      node.stamp = static_cast<double>(nodes.size());
      node.global = ls::Relative(*start, truth);
      node.points = std::make_shared<const ls::PointCloud>(ls::testing::ScanPoints(walls, truth));
      nodes.push_back(node);
    }
  }
  return nodes;
}

// A worker on a map of robot "a" (tied in at `origin_a`) and robot "b" joined with no start pose,
// every node of both there from the first pass (as a replay faster than the searches gives
// them). Runs until b is tied in and three more passes found nothing to do, or a bound far above
// the searches' cost (well under a second here) that a working worker never reaches: the test
// waits for what it does, not for a time. Returns the ties stored, (session, tie).
std::vector<std::pair<std::string, storage::MapTie>> TieIn(const std::vector<ls::NodeView>& a,
                                                           const storage::MapTie& origin_a,
                                                           const std::vector<ls::NodeView>& b) {
  std::mutex mu;
  std::condition_variable tied_cv;
  std::vector<std::pair<std::string, storage::MapTie>> ties;
  int passes_after_tie = 0;
  MapTieWorker::Sources sources;
  sources.maps_to_tie = [&] {
    std::lock_guard<std::mutex> lock(mu);
    if (!ties.empty()) {
      // Every robot is in the map: MapRegistry::MapsToTie has nothing to give.
      ++passes_after_tie;
      tied_cv.notify_all();
      return std::vector<storage::MapRecord>{};
    }
    storage::MapRecord map;
    map.name = "office";
    storage::MapTrajectoryRecord first, second;
    first.session_id = "a";
    first.tie = origin_a;
    second.session_id = "b";
    map.trajectories = {first, second};
    return std::vector<storage::MapRecord>{map};
  };
  sources.nodes = [&](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    if (id == "a") return TrajectoryNodes{a, /*resident=*/false};  // closed: read once
    if (id == "b") return TrajectoryNodes{b, /*resident=*/true};
    return absl::NotFoundError(id);
  };
  sources.resident = [](const std::string& id) { return id == "b"; };
  sources.tie = [&](const std::string& map, const std::string& id, const storage::MapTie& tie) {
    EXPECT_EQ(map, "office");
    std::lock_guard<std::mutex> lock(mu);
    ties.emplace_back(id, tie);
    tied_cv.notify_all();
    return absl::OkStatus();
  };
  MapTieWorker::Options options;
  options.poll_seconds = 0.01;
  MapTieWorker worker(std::move(sources), options);
  {
    std::unique_lock<std::mutex> lock(mu);
    EXPECT_TRUE(tied_cv.wait_for(lock, std::chrono::seconds(120), [&] {
      return passes_after_tie >= 3;
    })) << "no tie";
  }
  worker.Stop();
  return ties;
}

void ExpectTiedAt(const std::vector<std::pair<std::string, storage::MapTie>>& ties,
                  const ls::Pose2& truth) {
  ASSERT_EQ(ties.size(), 1u);
  EXPECT_EQ(ties[0].first, "b");
  EXPECT_NEAR(ties[0].second.x, truth.x, 0.03);
  EXPECT_NEAR(ties[0].second.y, truth.y, 0.03);
  EXPECT_NEAR(std::remainder(ties[0].second.theta - truth.theta, 2 * M_PI), 0.0, M_PI / 180);
}

// Robot a's and robot b's drives through PillarOffice, each in its own frame (its start).
struct OfficeDrives {
  std::vector<ls::NodeView> a, b;
  ls::Pose2 start_a, start_b;
};
OfficeDrives PillarOfficeDrives() {
  const std::vector<Wall> walls = PillarOffice();
  OfficeDrives d;
  d.a = Drive(walls, {{2.0, 4.5}, {12.0, 4.5}, {12.0, 7.0}, {3.0, 7.0}}, &d.start_a);
  d.b = Drive(walls, {{15.5, 6.5}, {6.0, 6.5}, {6.5, 3.5}}, &d.start_b);
  return d;
}

// The map "office" as stored: robot a closed and tied in at the origin with `a_scans` processed,
// robot b open (on another server) with `b_scans` in its record, tied in when `b_tied`.
storage::MapRecord OfficeOfTwo(int64_t a_scans, int64_t b_scans, bool b_tied) {
  storage::MapRecord map;
  map.name = "office";
  storage::MapTrajectoryRecord first, second;
  first.session_id = "a";
  first.tie = storage::MapTie{};
  first.session_state = storage::SlamSessionState::kClosed;
  first.scans_processed = a_scans;
  second.session_id = "b";
  second.scans_processed = b_scans;
  if (b_tied) second.tie = storage::MapTie{};
  map.trajectories = {first, second};
  return map;
}

TEST(MapTieWorkerTest, ASecondRobotIsFoundAndTiedInOnceAtTheTruth) {
  const OfficeDrives d = PillarOfficeDrives();
  const storage::MapTie origin_a{1.0, -2.0, 0.3};
  const ls::Pose2 truth = ls::Compose(ls::Pose2{origin_a.x, origin_a.y, origin_a.theta},
                                      ls::Relative(d.start_a, d.start_b));
  ExpectTiedAt(TieIn(d.a, origin_a, d.b), truth);
}

// The tie is checked against the map (TieKeepsTheMapConsistent) on the joining robot's nodes up to
// the scan it was tied at, as a robot at its own pace is: here robot b's odometry turns 0.3 rad
// wrong as it goes through a door into a second room, so its nodes there, placed by the one
// origin of the tie, contradict robot a's map of that room. Judged on all of b's nodes (what a
// replay faster than the searches handed the check before), the right tie was refused.
TEST(MapTieWorkerTest, ATieIsJudgedOnTheNodesTheRobotHadWhenItWasFound) {
  // PillarOffice with a door in its east wall (y 5.5 to 6.5) into a second room, 12 x 12 m, with
  // pillars of its own.
  std::vector<Wall> walls;
  for (const Wall& w : PillarOffice()) {
    if (!(w.a.x() == 20.0 && w.b.x() == 20.0)) walls.push_back(w);
  }
  walls.push_back({{20.0, 0.0}, {20.0, 5.5}});
  walls.push_back({{20.0, 6.5}, {20.0, 12.0}});
  for (const Wall& w : Box(20.0, 0.0, 32.0, 12.0)) {
    if (!(w.a.x() == 20.0 && w.b.x() == 20.0)) walls.push_back(w);
  }
  for (const std::vector<Wall>& pillar : {Box(24.0, 2.0, 25.0, 3.0), Box(27.0, 8.0, 28.5, 8.6)}) {
    walls.insert(walls.end(), pillar.begin(), pillar.end());
  }
  ls::Pose2 start_a, start_b;
  const std::vector<ls::NodeView> a = Drive(
      walls, {{2.0, 4.5}, {12.0, 4.5}, {12.0, 7.0}, {18.0, 6.0}, {26.0, 6.0}, {26.0, 10.0},
              {30.0, 10.0}, {30.0, 4.5}, {22.0, 4.5}},
      &start_a);
  std::vector<ls::NodeView> b =
      Drive(walls, {{6.0, 6.5}, {15.5, 6.5}, {19.0, 6.0}, {26.0, 6.0}, {26.0, 2.0}}, &start_b);
  // Past the door, b's own poses turn 0.3 rad about the door: its odometry went wrong there.
  const ls::Pose2 door = ls::Relative(start_b, ls::Pose2{20.0, 6.0, 0.0});
  const ls::Pose2 turn = ls::Compose(ls::Compose(door, ls::Pose2{0.0, 0.0, 0.3}), ls::Invert(door));
  int bent = 0;
  for (ls::NodeView& node : b) {
    if (ls::Compose(start_b, node.global).x > 20.0) {
      node.global = ls::Compose(turn, node.global);
      ++bent;
    }
  }
  ASSERT_GT(bent, 20);
  const storage::MapTie origin_a{1.0, -2.0, 0.3};
  const ls::Pose2 truth = ls::Compose(ls::Pose2{origin_a.x, origin_a.y, origin_a.theta},
                                      ls::Relative(start_a, start_b));
  ExpectTiedAt(TieIn(a, origin_a, b), truth);
}

// On a fleet: a map whose lease another server holds is not searched (its nodes are not even
// read); once this server owns it, a robot streaming to another server (not resident here, its
// nodes read from its checkpoint) is read again only when its record shows more scans, and is
// then tied in.
TEST(MapTieWorkerTest, OnlyAnOwnedMapIsSearchedAndARobotElsewhereIsReadAsItGoesOn) {
  const OfficeDrives drives = PillarOfficeDrives();
  const std::vector<ls::NodeView>& a = drives.a;
  const std::vector<ls::NodeView>& b = drives.b;
  // 0.75 m of travel: too little for two agreeing matches 2 m apart.
  const std::vector<ls::NodeView> b_start(b.begin(), b.begin() + 3);

  enum Phase { kOwnedElsewhere, kOwnedFewScans, kOwnedAllScans };
  std::mutex mu;
  std::condition_variable cv;
  Phase phase = kOwnedElsewhere;
  int passes = 0, b_reads = 0, own_asked = 0;
  bool tied = false;
  MapTieWorker::Sources sources;
  sources.maps_to_tie = [&] {
    std::lock_guard<std::mutex> lock(mu);
    ++passes;
    cv.notify_all();
    if (tied) return std::vector<storage::MapRecord>{};
    return std::vector<storage::MapRecord>{OfficeOfTwo(
        static_cast<int64_t>(a.back().scan),
        static_cast<int64_t>(phase == kOwnedAllScans ? b.back().scan : b_start.back().scan),
        /*b_tied=*/false)};
  };
  sources.nodes = [&](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    std::lock_guard<std::mutex> lock(mu);
    EXPECT_NE(phase, kOwnedElsewhere) << "read the nodes of a map another server owns";
    if (id == "a") return TrajectoryNodes{a, /*resident=*/false};
    if (id == "b") {
      ++b_reads;
      return TrajectoryNodes{phase == kOwnedAllScans ? b : b_start, /*resident=*/false};
    }
    return absl::NotFoundError(id);
  };
  sources.resident = [](const std::string&) { return false; };
  sources.own = [&](const std::string& map) {
    EXPECT_EQ(map, "office");
    std::lock_guard<std::mutex> lock(mu);
    ++own_asked;
    return phase != kOwnedElsewhere;
  };
  sources.tie = [&](const std::string&, const std::string& id, const storage::MapTie&) {
    std::lock_guard<std::mutex> lock(mu);
    EXPECT_EQ(id, "b");
    EXPECT_EQ(phase, kOwnedAllScans) << "tied in from 0.75 m of travel";
    tied = true;
    cv.notify_all();
    return absl::OkStatus();
  };
  MapTieWorker::Options options;
  options.poll_seconds = 0.01;
  MapTieWorker worker(std::move(sources), options);
  // Bounds far above what the passes cost, never reached when the worker works.
  const auto wait_passes = [&](std::unique_lock<std::mutex>& lock, int more) {
    const int until = passes + more;
    return cv.wait_for(lock, std::chrono::seconds(120), [&] { return passes >= until; });
  };
  {
    std::unique_lock<std::mutex> lock(mu);
    ASSERT_TRUE(wait_passes(lock, 5));
    EXPECT_GE(own_asked, 4);  // the fifth pass may not have asked yet
    EXPECT_EQ(b_reads, 0);
    phase = kOwnedFewScans;
    ASSERT_TRUE(wait_passes(lock, 10));
    EXPECT_EQ(b_reads, 1);  // read once: its record shows no new scans
    EXPECT_FALSE(tied);
    phase = kOwnedAllScans;
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(120), [&] { return tied; })) << "no tie";
    EXPECT_EQ(b_reads, 2);
  }
  worker.Stop();
}

// A feed in memory, as MapStore keeps one (storage/map_store.h: versions, points by scan,
// pruned rows and a publisher's replace); the store's own test runs the SQL on both backends.
struct FakeFeeds {
  struct Feed {
    int64_t version = 0;
    int64_t scans = 0;
    std::string poses;
    std::map<int64_t, std::string> points;
  };
  std::mutex mu;
  std::map<std::string, Feed> feeds;
  int publishes = 0;

  absl::StatusOr<int64_t> Publish(const std::string& id,
                                  const storage::TrajectoryFeedUpdate& update) {
    std::lock_guard<std::mutex> lock(mu);
    Feed& feed = feeds[id];
    if (update.replace) feed.points.clear();
    for (const int64_t scan : update.dropped) feed.points.erase(scan);
    for (const storage::FeedNodePoints& node : update.added) feed.points[node.scan] = node.points;
    feed.scans = update.scans_processed;
    feed.poses = update.poses;
    ++publishes;
    return ++feed.version;
  }
  absl::StatusOr<std::optional<storage::TrajectoryFeed>> Read(const std::string& id,
                                                              int64_t after_version,
                                                              int64_t after_scan) {
    std::lock_guard<std::mutex> lock(mu);
    auto it = feeds.find(id);
    if (it == feeds.end() || it->second.version <= after_version) {
      return std::optional<storage::TrajectoryFeed>();
    }
    storage::TrajectoryFeed out;
    out.version = it->second.version;
    out.scans_processed = it->second.scans;
    out.poses = it->second.poses;
    for (const auto& [scan, points] : it->second.points) {
      if (scan > after_scan) out.points.push_back({scan, points});
    }
    return std::optional<storage::TrajectoryFeed>(std::move(out));
  }
};

// On a fleet the robot streams to one server and its map's owner is another. Server B holds
// robot b in memory and does not own the map: it publishes b's nodes as they come. Server A owns
// the map and holds b only as its stale checkpoint (three nodes, too few to tie it in): it reads
// the rest from the feed and ties b in at the truth, without a newer checkpoint.
TEST(MapTieWorkerTest, TheOwnerTiesInARobotElsewhereFromTheNodesItsServerPublishes) {
  const OfficeDrives d = PillarOfficeDrives();
  const std::vector<ls::NodeView> b_checkpoint(d.b.begin(), d.b.begin() + 3);
  FakeFeeds feeds;
  std::mutex mu;
  std::condition_variable cv;
  std::vector<std::pair<std::string, storage::MapTie>> ties;
  std::size_t b_nodes_now = 3;  // how many nodes robot b has on server B so far
  int checkpoint_reads = 0;

  // Robot b's checkpoint stopped at its third node.
  const auto office = [&](bool b_tied) {
    return std::vector<storage::MapRecord>{OfficeOfTwo(static_cast<int64_t>(d.a.back().scan),
                                                       static_cast<int64_t>(b_checkpoint.back().scan),
                                                       b_tied)};
  };

  // Server B: b in memory, growing by a node a pass; the map owned elsewhere.
  MapTieWorker::Sources on_b;
  on_b.maps_to_tie = [&] {
    std::lock_guard<std::mutex> lock(mu);
    b_nodes_now = std::min(d.b.size(), b_nodes_now + 1);
    return ties.empty() ? office(false) : std::vector<storage::MapRecord>{};
  };
  on_b.nodes = [&](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    EXPECT_EQ(id, "b") << "server B read a session it does not hold";
    std::lock_guard<std::mutex> lock(mu);
    TrajectoryNodes nodes{std::vector<ls::NodeView>(d.b.begin(), d.b.begin() + b_nodes_now),
                          /*resident=*/true};
    nodes.scans_processed = static_cast<int64_t>(nodes.nodes.back().scan);
    return nodes;
  };
  on_b.resident = [](const std::string& id) { return id == "b"; };
  on_b.own = [](const std::string&) { return false; };
  on_b.holds = [](const std::string&) { return false; };
  on_b.tie = [](const std::string&, const std::string&, const storage::MapTie&) {
    ADD_FAILURE() << "server B tied a robot of a map it does not own";
    return absl::OkStatus();
  };
  on_b.publish = [&](const std::string& id, const storage::TrajectoryFeedUpdate& update) {
    return feeds.Publish(id, update);
  };
  on_b.maps_to_publish = [&] {
    std::lock_guard<std::mutex> lock(mu);
    return office(!ties.empty());
  };

  // Server A: the map's owner; a and b only as their checkpoints.
  MapTieWorker::Sources on_a;
  on_a.maps_to_tie = [&] {
    std::lock_guard<std::mutex> lock(mu);
    cv.notify_all();
    return ties.empty() ? office(false) : std::vector<storage::MapRecord>{};
  };
  on_a.nodes = [&](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    std::lock_guard<std::mutex> lock(mu);
    if (id == "a") return TrajectoryNodes{d.a, /*resident=*/false};
    ++checkpoint_reads;
    return TrajectoryNodes{b_checkpoint, /*resident=*/false};
  };
  on_a.resident = [](const std::string&) { return false; };
  on_a.own = [](const std::string&) { return true; };
  on_a.tie = [&](const std::string&, const std::string& id, const storage::MapTie& tie) {
    std::lock_guard<std::mutex> lock(mu);
    ties.emplace_back(id, tie);
    cv.notify_all();
    return absl::OkStatus();
  };
  on_a.read_feed = [&](const std::string& id, int64_t after_version, int64_t after_scan) {
    return feeds.Read(id, after_version, after_scan);
  };

  MapTieWorker::Options options;
  options.poll_seconds = 0.01;
  options.feed_seconds = 0.0001;
  MapTieWorker server_b(std::move(on_b), options);
  MapTieWorker server_a(std::move(on_a), options);
  {
    // A bound far above what the passes cost, never reached when the feed works.
    std::unique_lock<std::mutex> lock(mu);
    EXPECT_TRUE(cv.wait_for(lock, std::chrono::seconds(120), [&] { return !ties.empty(); }))
        << "no tie from the feed";
  }
  server_a.Stop();
  server_b.Stop();
  const ls::Pose2 truth = ls::Relative(d.start_a, d.start_b);
  ExpectTiedAt(ties, truth);
  EXPECT_LE(checkpoint_reads, 1);  // at most before the first publish
  std::lock_guard<std::mutex> lock(feeds.mu);
  EXPECT_GT(feeds.publishes, 1);
  // Each node's points were published once: the feed holds every node b had.
  EXPECT_EQ(feeds.feeds["b"].points.size(), b_nodes_now);
}

TEST(MapTieWorkerTest, StopsWithNothingToDo) {
  MapTieWorker::Sources sources;
  sources.maps_to_tie = [] { return std::vector<storage::MapRecord>{}; };
  sources.nodes = [](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    return absl::NotFoundError(id);
  };
  sources.resident = [](const std::string&) { return false; };
  sources.tie = [](const std::string&, const std::string&, const storage::MapTie&) {
    ADD_FAILURE() << "nothing to tie";
    return absl::OkStatus();
  };
  MapTieWorker worker(std::move(sources), MapTieWorker::Options{});
  worker.Stop();
  worker.Stop();  // idempotent, as the destructor calls it again
}

}  // namespace
}  // namespace waymark::service

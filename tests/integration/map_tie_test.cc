// Issue 38's tie on a real log, against the real waymark-server binary: ACES (../shared, skipped
// when absent) split into two overlapping slices replayed as two robots into one map, with no
// start pose for the second. The server must find the second robot in the first one's map and
// tie it in, and its map-frame trajectory must agree with the single session that drove the
// same scans in one go (whose frame is the first robot's: both start at scan 0). Also the merged
// grid of the two and `slam trajectory --frame map`.

#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "client/datasets/tum_trajectory.h"
#include "tests/client/test_util.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

namespace fs = std::filesystem;
using testing::RunWaymark;

// The slices: robot 1 drives scans 0-1499, robot 2 scans 1000-2499 (a third of it overlaps).
constexpr char kFirst[] = "0:1500";
constexpr char kSecond[] = "1000:2500";
constexpr char kSingle[] = "0:2500";

std::map<double, cli::Pose2> ByStamp(const fs::path& tum) {
  absl::StatusOr<std::vector<cli::StampedPose>> poses = cli::ReadTumFile(tum);
  EXPECT_TRUE(poses.ok()) << tum << ": " << poses.status();
  std::map<double, cli::Pose2> out;
  if (poses.ok()) {
    for (const cli::StampedPose& p : *poses) out[std::round(p.stamp * 1e4) / 1e4] = p.pose;
  }
  return out;
}

// Where two trajectories share a stamp: position differences (summed, worst) and the worst
// heading difference.
struct Disagreement {
  double sum = 0, worst = 0, worst_heading = 0;
  int compared = 0;
};

Disagreement Compare(const std::map<double, cli::Pose2>& a,
                     const std::map<double, cli::Pose2>& b) {
  Disagreement d;
  for (const auto& [stamp, pose] : a) {
    auto it = b.find(stamp);
    if (it == b.end()) continue;
    const double error = std::hypot(pose.x - it->second.x, pose.y - it->second.y);
    d.sum += error;
    d.worst = std::max(d.worst, error);
    d.worst_heading = std::max(
        d.worst_heading, std::abs(std::remainder(pose.theta - it->second.theta, 2 * M_PI)));
    ++d.compared;
  }
  return d;
}

TEST(MapTieTest, TheSecondRobotOfAcesIsTiedInAndAgreesWithOneSession) {
  const fs::path log = fs::path(WAYMARK_SHARED_DIR) / "data/laser/aces/aces.clf.bz2";
  if (!fs::exists(log)) GTEST_SKIP() << log << " not present";
  testing::ScopedTempDir temp;
  const fs::path dir = temp.Make("tie");
  fs::create_directories(dir);
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), (dir / "waymark.db").string(),
                                              {"--slam-workers", "2"});
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string address = (*server)->address();
  const auto run = [&](std::vector<std::string> args) {
    const testing::CliResult result = RunWaymark(address, args);
    EXPECT_EQ(result.code, 0) << result.err << result.out << (*server)->Log();
    return result;
  };

  run({"map", "create", "aces"});
  run({"slam", "replay", log.string(), "--map", "aces", "--scans", kFirst, "--robot", "r1", "--out",
       (dir / "r1").string()});
  run({"slam", "replay", log.string(), "--map", "aces", "--scans", kSecond, "--robot", "r2",
       "--out", (dir / "r2").string()});

  // The tie runs beside the sessions and may finish after the replay: waited for, within a
  // bound far above what it takes (the searches of 1500 scans, a few seconds of one core).
  nlohmann::json map;
  for (int attempt = 0; attempt < 240; ++attempt) {
    map = run({"--json", "map", "show", "aces"}).Json();
    if (map["trajectories"].size() == 2 && map["trajectories"][1].value("tied_in", false)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  ASSERT_EQ(map["trajectories"].size(), 2u);
  ASSERT_TRUE(map["trajectories"][1].value("tied_in", false))
      << "the second robot was not tied in\n" << (*server)->Log();
  // Two joined, one tied in (3); then one more each time following robot 2 after its tie moved
  // its stored origin by more than a few cm (MapRegistry::Follow).
  EXPECT_GE(map["revision"], 3);
  const std::string second = map["trajectories"][1]["session_id"];

  // Its poses in the map frame, against the single session on the same scans.
  run({"slam", "trajectory", second, "--frame", "map", "--out", (dir / "r2_map.txt").string()});
  run({"slam", "replay", log.string(), "--scans", kSingle, "--robot", "single", "--out",
       (dir / "single").string()});
  const std::map<double, cli::Pose2> merged = ByStamp(dir / "r2_map.txt");
  const std::map<double, cli::Pose2> single = ByStamp(dir / "single" / "trajectory.txt");
  ASSERT_EQ(merged.size(), 1500u);
  const Disagreement all = Compare(merged, single);
  ASSERT_GE(all.compared, 1400);
  // Where both robots drove (scans 1000-1500), robot 2 in the map frame against robot 1: what the
  // tie itself gets right. Measured 2026-12-07 (ACES): mean 0.068 m, worst 0.112 m; the floors
  // are 1.5 times that. A tie a degree off moves the overlap's far end (15 m away) by 0.26 m.
  const Disagreement overlap = Compare(merged, ByStamp(dir / "r1" / "trajectory.txt"));
  ASSERT_GE(overlap.compared, 450);
  EXPECT_LT(overlap.sum / overlap.compared, 0.10);
  EXPECT_LT(overlap.worst, 0.17);
  // Against the single session over all of robot 2's scans: where robot 2 drives alone the two
  // sessions' graphs differ, each right on the relations (0.037 m on ACES's for both), so this
  // measures the graphs' own disagreement more than the tie. Measured: mean 0.159 m, worst 0.280
  // m, worst heading 0.037 rad when this test was written; 2026-12-06 mean 0.111, worst 0.408,
  // heading 0.025 (0.109 and 0.424 with the scans between nodes interpolated); 2026-12-07, with
  // the front end's wider window for a turn its prior missed (3 of ACES's 1426 local matches),
  // mean 0.370, worst 0.646. The floors: 1.5 times the largest measured. Without the tie there
  // is no map-frame trajectory at all (`--frame map` refuses).
  EXPECT_LT(all.sum / all.compared, 0.56);
  EXPECT_LT(all.worst, 0.97);
  EXPECT_LT(all.worst_heading, 0.056);

  // The merged grid: both trajectories in one grid of the map frame.
  const nlohmann::json grid =
      run({"--json", "map", "grid", "aces", "--out", (dir / "grid").string()}).Json();
  EXPECT_TRUE(fs::exists(dir / "grid" / "map.pgm"));
  EXPECT_NE(grid.dump().find(second), std::string::npos) << grid.dump();
}

}  // namespace
}  // namespace waymark

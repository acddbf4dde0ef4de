// Occupancy grids on the command line against the in-memory fake SlamService: the SlamClient
// wrappers' retry policy, `slam map` writing map.pgm / map.yaml / occupancy.png (or saying why
// there is no grid), `slam import-map`, and the grid at the end of `slam replay`.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "client/datasets/ros_map.h"
#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "tests/client/carmen_test_log.h"
#include "tests/client/fake_slam_cli_test.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::MakeLog;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

// 7 x 4 cells of 0.05 m from (-0.2, 0.35): -1, 0 and 100 in a pattern no flip leaves alone.
v1::OccupancyGrid TestGrid() {
  v1::OccupancyGrid grid;
  grid.set_width(7);
  grid.set_height(4);
  grid.set_resolution(0.05);
  grid.mutable_origin()->set_x(-0.2);
  grid.mutable_origin()->set_y(0.35);
  grid.set_map_revision(3);
  grid.set_scans(20);
  std::string cells;
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 7; ++x) {
      const int k = (x + 2 * y + x * y) % 3;
      cells.push_back(static_cast<char>(k == 0 ? -1 : k == 1 ? 0 : 100));
    }
  }
  grid.set_cells(cells);
  return grid;
}

void ExpectSameGrid(const v1::OccupancyGrid& actual, const v1::OccupancyGrid& expected) {
  EXPECT_EQ(actual.width(), expected.width());
  EXPECT_EQ(actual.height(), expected.height());
  EXPECT_DOUBLE_EQ(actual.resolution(), expected.resolution());
  EXPECT_DOUBLE_EQ(actual.origin().x(), expected.origin().x());
  EXPECT_DOUBLE_EQ(actual.origin().y(), expected.origin().y());
  EXPECT_EQ(actual.cells(), expected.cells());
}

class GridCommandsTest : public ::waymark::testing::FakeSlamCliTest {
 protected:
  // A closed session s1 from a replay of a 20-scan log (into a folder of its own).
  void ReplaySession() {
    const auto log = dir_.path() / "test.clf";
    std::ofstream(log) << MakeLog(20);
    CliResult r = Run({"slam", "replay", log.string(), "--out", (dir_.path() / "replay").string()});
    ASSERT_EQ(r.code, 0) << r.err;
  }

};

TEST_F(GridCommandsTest, GetOccupancyGridIsRetriedAndImportMapIsNot) {
  client::SlamClientOptions options;
  options.retry.initial_backoff = absl::Milliseconds(1);
  options.retry.max_backoff = absl::Milliseconds(5);
  client::SlamClient client(client::MakeChannel(server_.address()), options);
  auto imported = client.ImportMap("r1", "hall", TestGrid());
  ASSERT_TRUE(imported.ok()) << imported.status();
  EXPECT_EQ(imported->state(), v1::Session::CLOSED);
  EXPECT_EQ(server_.service().last_import().robot_id(), "r1");
  EXPECT_EQ(server_.service().last_import().name(), "hall");

  server_.service().FailNext("GetOccupancyGrid", 2);
  auto grid = client.GetOccupancyGrid(imported->session_id(), 0.1);
  ASSERT_TRUE(grid.ok()) << grid.status();
  EXPECT_EQ(server_.service().calls("GetOccupancyGrid"), 3);
  ExpectSameGrid(*grid, TestGrid());
  EXPECT_EQ(server_.service().last_grid_resolution(), 0.1);
  ASSERT_TRUE(client.GetOccupancyGrid(imported->session_id()).ok());
  EXPECT_EQ(server_.service().last_grid_resolution(), std::nullopt);

  server_.service().FailNext("ImportMap", 1);
  const int before = server_.service().calls("ImportMap");
  EXPECT_EQ(client.ImportMap("r1", "again", TestGrid()).status().code(),
            absl::StatusCode::kUnavailable);
  EXPECT_EQ(server_.service().calls("ImportMap"), before + 1);
}

TEST_F(GridCommandsTest, MapWritesTheGridAsRosMapFilesAndAPicture) {
  server_.service().set_occupancy_grid(TestGrid());
  ReplaySession();
  const auto out = dir_.path() / "map";
  CliResult r = Run({"--json", "slam", "map", "s1", "--out", out.string(), "--resolution", "0.05"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(server_.service().last_grid_resolution(), 0.05);
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["files"].size(), 6u);  // trajectory.txt, map.svg, map.png + the grid's three
  EXPECT_EQ(json["grid"]["width"], 7);
  EXPECT_EQ(json["grid"]["height"], 4);
  EXPECT_FALSE(json.contains("grid_note"));
  auto read = ReadRosMap(out / "map.yaml");
  ASSERT_TRUE(read.ok()) << read.status();
  ExpectSameGrid(*read, TestGrid());
  const cv::Mat picture = cv::imread((out / "occupancy.png").string());
  ASSERT_FALSE(picture.empty());
  EXPECT_EQ(picture.cols, 7 * 74);  // scaled up to at least 512 pixels: 74 per cell
  EXPECT_FALSE(cv::imread((out / "map.png").string()).empty());

  CliResult human = Run({"slam", "map", "s1", "--out", (dir_.path() / "h").string()});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, HasSubstr("occupancy grid 7 x 4 cells at 0.05 m, origin (-0.2, 0.35)"));
  EXPECT_THAT(human.out, HasSubstr("map.pgm, map.yaml, occupancy.png"));
  EXPECT_EQ(server_.service().last_grid_resolution(), std::nullopt);  // the server's default
}

TEST_F(GridCommandsTest, MapOfASessionWithoutAGridStillWritesTheSegmentMapAndSaysWhy) {
  ReplaySession();  // the fake has no grid: FAILED_PRECONDITION, as loop closure off
  const auto out = dir_.path() / "map";
  CliResult r = Run({"slam", "map", "s1", "--out", out.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("no occupancy grid for session s1: fake: session 's1' keeps no "
                               "scans (loop closure off)"));
  EXPECT_TRUE(std::filesystem::exists(out / "map.svg"));
  EXPECT_FALSE(std::filesystem::exists(out / "map.pgm"));
  EXPECT_FALSE(std::filesystem::exists(out / "occupancy.png"));
  CliResult json = Run({"--json", "slam", "map", "s1", "--out", out.string()});
  ASSERT_EQ(json.code, 0) << json.err;
  EXPECT_TRUE(json.Json()["grid"].is_null());
  EXPECT_THAT(json.Json()["grid_note"].get<std::string>(), HasSubstr("keeps no scans"));

  server_.service().set_grid_answer(grpc::StatusCode::UNIMPLEMENTED);  // an older server
  CliResult old = Run({"slam", "map", "s1", "--out", out.string()});
  ASSERT_EQ(old.code, 0) << old.err;
  EXPECT_THAT(old.out, HasSubstr("no occupancy grid: the server does not serve them"));

  server_.service().set_grid_answer(grpc::StatusCode::PERMISSION_DENIED);  // a real refusal
  CliResult refused = Run({"slam", "map", "s1", "--out", out.string()});
  EXPECT_EQ(refused.code, 1);
  EXPECT_THAT(refused.err, HasSubstr("error: PERMISSION_DENIED"));
  EXPECT_THAT(refused.err, HasSubstr("(GetOccupancyGrid)"));
}

TEST_F(GridCommandsTest, MapToOnePictureDoesNotAskForTheGrid) {
  server_.service().set_occupancy_grid(TestGrid());
  ReplaySession();
  const int before = server_.service().calls("GetOccupancyGrid");  // the replay asked once
  CliResult r = Run({"slam", "map", "s1", "--out", (dir_.path() / "only.svg").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(server_.service().calls("GetOccupancyGrid"), before);
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "map.pgm"));
}

TEST_F(GridCommandsTest, MapArgumentErrors) {
  for (const std::string resolution : {"0", "5", "fine"}) {
    SCOPED_TRACE(resolution);
    CliResult r = Run({"slam", "map", "s1", "--resolution", resolution});
    EXPECT_NE(r.code, 0);
    EXPECT_THAT(r.err, HasSubstr("--resolution"));
  }
  CliResult no_session = Run({"slam", "map"});
  EXPECT_NE(no_session.code, 0);
  EXPECT_THAT(no_session.err, HasSubstr("SESSION is required"));
  EXPECT_EQ(server_.service().calls("GetOccupancyGrid"), 0);
}

TEST_F(GridCommandsTest, ImportMapStoresTheFilesAsASession) {
  ASSERT_TRUE(WriteRosMap(TestGrid(), dir_.path() / "saved").ok());
  const std::string yaml = (dir_.path() / "saved" / "map.yaml").string();
  CliResult r = Run({"slam", "import-map", yaml, "--name", "hall", "--robot", "r9"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("(7 x 4 cells at 0.05 m, origin (-0.2, 0.35)) as session s1"));
  EXPECT_THAT(r.out, HasSubstr("--localize-on s1"));
  const v1::ImportMapRequest request = server_.service().last_import();
  EXPECT_EQ(request.robot_id(), "r9");
  EXPECT_EQ(request.name(), "hall");
  ExpectSameGrid(request.grid(), TestGrid());

  CliResult json = Run({"--json", "slam", "import-map", yaml});
  ASSERT_EQ(json.code, 0) << json.err;
  EXPECT_EQ(json.Json()["session_id"], "s2");
  EXPECT_EQ(json.Json()["state"], "closed");
  EXPECT_EQ(json.Json()["grid"]["width"], 7);
  EXPECT_EQ(server_.service().last_import().robot_id(), "maps");
  EXPECT_EQ(server_.service().last_import().name(), "import of " + yaml);
}

TEST_F(GridCommandsTest, AGridTakenAwayWithMapComesBackWithImportMap) {
  server_.service().set_occupancy_grid(TestGrid());
  ReplaySession();
  const auto out = dir_.path() / "map";
  ASSERT_EQ(Run({"slam", "map", "s1", "--out", out.string()}).code, 0);
  CliResult imported = Run({"--json", "slam", "import-map", (out / "map.yaml").string()});
  ASSERT_EQ(imported.code, 0) << imported.err;
  const std::string id = imported.Json()["session_id"];
  client::SlamClient client(client::MakeChannel(server_.address()));
  auto grid = client.GetOccupancyGrid(id);
  ASSERT_TRUE(grid.ok()) << grid.status();
  ExpectSameGrid(*grid, TestGrid());
}

TEST_F(GridCommandsTest, ImportMapErrorsNameTheFileAndCallNoServer) {
  CliResult missing = Run({"slam", "import-map", (dir_.path() / "none.yaml").string()});
  EXPECT_EQ(missing.code, 1);
  EXPECT_THAT(missing.err, HasSubstr("error: NOT_FOUND: no file '"));
  EXPECT_THAT(missing.err, HasSubstr("none.yaml"));

  const auto bad = dir_.path() / "bad.yaml";
  std::ofstream(bad) << "image: map.pgm\nresolution: -1\n";
  CliResult invalid = Run({"slam", "import-map", bad.string()});
  EXPECT_EQ(invalid.code, 1);
  EXPECT_THAT(invalid.err, HasSubstr("error: INVALID_ARGUMENT: " + bad.string() +
                                     ": line 2: 'resolution': must be positive"));

  CliResult no_file = Run({"slam", "import-map"});
  EXPECT_NE(no_file.code, 0);
  EXPECT_THAT(no_file.err, HasSubstr("MAP_YAML is required"));
  EXPECT_EQ(server_.service().calls("ImportMap"), 0);

  // A refusal by the server is reported as such (and a write is not retried).
  ASSERT_TRUE(WriteRosMap(TestGrid(), dir_.path() / "saved").ok());
  server_.service().FailNext("ImportMap", 1);
  CliResult down = Run({"slam", "import-map", (dir_.path() / "saved" / "map.yaml").string()});
  EXPECT_EQ(down.code, 1);
  EXPECT_THAT(down.err, HasSubstr("UNAVAILABLE"));
  EXPECT_EQ(server_.service().calls("ImportMap"), 1);

  server_.service().FailNext("ImportMap", 1, grpc::StatusCode::UNIMPLEMENTED);
  CliResult old = Run({"slam", "import-map", (dir_.path() / "saved" / "map.yaml").string()});
  EXPECT_EQ(old.code, 1);
  EXPECT_THAT(old.err, HasSubstr("error: UNIMPLEMENTED: the server does not import maps: it is "
                                 "older than this client (ImportMap)"));
}

TEST_F(GridCommandsTest, ReplayWritesTheGridIntoItsFolder) {
  server_.service().set_occupancy_grid(TestGrid());
  const auto out = dir_.path() / "o";
  CliResult r = Run(
      {"--json", "slam", "replay", WriteLog(20), "--out", out.string(), "--resolution", "0.1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(server_.service().last_grid_resolution(), 0.1);
  const nlohmann::json summary =
      nlohmann::json::parse(waymark::testing::ReadAll(out / "summary.json"));
  EXPECT_EQ(summary["grid"]["width"], 7);
  EXPECT_DOUBLE_EQ(summary["grid"]["resolution"].get<double>(), 0.05);
  EXPECT_FALSE(summary.contains("grid_note"));
  std::vector<std::string> names;
  for (const auto& file : summary["files"]) {
    names.push_back(std::filesystem::path(file.get<std::string>()).filename().string());
  }
  EXPECT_THAT(names, ::testing::IsSupersetOf({"map.pgm", "map.yaml", "occupancy.png"}));
  auto read = ReadRosMap(out / "map.yaml");
  ASSERT_TRUE(read.ok()) << read.status();
  ExpectSameGrid(*read, TestGrid());
  EXPECT_FALSE(cv::imread((out / "occupancy.png").string()).empty());
}

TEST_F(GridCommandsTest, AReplayNeverFailsForItsGrid) {
  const struct {
    grpc::StatusCode code;
    const char* note;
  } cases[] = {
      {grpc::StatusCode::OK, "keeps no scans"},  // no grid set: FAILED_PRECONDITION
      {grpc::StatusCode::UNIMPLEMENTED, "the server does not serve them"},
      {grpc::StatusCode::PERMISSION_DENIED, "GetOccupancyGrid: PERMISSION_DENIED"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.note);
    server_.service().set_grid_answer(c.code);
    const auto out = dir_.path() / ("o" + std::to_string(static_cast<int>(c.code)));
    CliResult r = Run({"slam", "replay", WriteLog(20), "--out", out.string()});
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_THAT(r.out, HasSubstr(c.note));
    EXPECT_THAT(r.out, HasSubstr("summary.json"));
    EXPECT_FALSE(std::filesystem::exists(out / "map.pgm"));
    const nlohmann::json summary =
        nlohmann::json::parse(waymark::testing::ReadAll(out / "summary.json"));
    EXPECT_TRUE(summary["grid"].is_null());
    EXPECT_THAT(summary["grid_note"].get<std::string>(), HasSubstr(c.note));
  }
}

TEST_F(GridCommandsTest, AReplayWhoseServerIsGoneDoesNotAskForTheGrid) {
  server_.service().set_occupancy_grid(TestGrid());
  server_.service().set_session_calls_fail(grpc::StatusCode::NOT_FOUND);
  const auto out = dir_.path() / "o";
  CliResult r = Run({"--json", "slam", "replay", WriteLog(20), "--out", out.string()});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(server_.service().calls("GetOccupancyGrid"), 0);
  EXPECT_THAT(r.Json()["grid_note"].get<std::string>(),
              HasSubstr("no occupancy grid: the server could not be asked (GetMap: NOT_FOUND"));
}

}  // namespace
}  // namespace waymark::cli

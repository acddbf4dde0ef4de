// The map's self-check on the command line, against the in-memory fake SlamService: `slam
// replay` prints it, writes it to summary.json, draws it on occupancy.png and exits 3
// (kExitInconsistentMap) when the final map contradicts itself, 0 with --allow-inconsistent-map or
// a consistent map; `slam list` shows each closed session's verdict.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "client/common/command_context.h"
#include "tests/client/fake_slam_cli_test.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::CliResult;

// 8 x 4 cells of 0.05 m from (-0.2, 0.35), all free: a picture of 8 * 64 = 512 x 256 pixels
// (64 per cell, 1280 per metre) on which the self-check's colours stand out.
v1::OccupancyGrid FreeGrid() {
  v1::OccupancyGrid grid;
  grid.set_width(8);
  grid.set_height(4);
  grid.set_resolution(0.05);
  grid.mutable_origin()->set_x(-0.2);
  grid.mutable_origin()->set_y(0.35);
  grid.set_cells(std::string(32, '\0'));
  return grid;
}

// A picture pixel of FreeGrid's occupancy.png at world (x, y).
cv::Point PixelOf(double x, double y) {
  constexpr double kPixelsPerMetre = 64 / 0.05;
  return cv::Point(static_cast<int>((x + 0.2) * kPixelsPerMetre),
                   static_cast<int>(256 - (y - 0.35) * kPixelsPerMetre));
}

// A map folded across itself: two areas contradict themselves, one contradicting cell at
// (0.125, 0.425) (far from the replay's path along y = 0), the worst area x 0..0.1, y 0.4..0.5.
v1::MapSelfCheck FoldedCheck() {
  v1::MapSelfCheck check;
  check.set_consistent(false);
  check.set_contradicted_fraction(0.079);
  check.set_areas_contradicting(2);
  check.set_verdict(
      "contradicts itself: 7.9% of 1000 wall cells contradicted both ways (limit 5.0%); 2 areas "
      "of 5 m contradict themselves (limit 2; an area: 20% and 20 cells; worst 45.0%)");
  check.set_nodes(100);
  check.set_submaps(4);
  check.set_resolution(0.05);
  check.set_contradicted(79);
  check.set_evidence(1000);
  v1::MapCheckArea* worst = check.add_worst_areas();
  worst->set_min_x(-0.15);
  worst->set_min_y(0.4);
  worst->set_size(0.1);
  worst->set_contradicted_fraction(0.45);
  worst->set_contradicted(45);
  worst->set_evidence(100);
  v1::MapCheckArea* next = check.add_worst_areas();
  *next = *worst;
  next->set_contradicted_fraction(0.3);
  check.add_contradicting_cells(0.125f);
  check.add_contradicting_cells(0.425f);
  check.set_contradicting_cell_count(1);
  return check;
}

v1::MapSelfCheck ConsistentCheck() {
  v1::MapSelfCheck check;
  check.set_consistent(true);
  check.set_contradicted_fraction(0.0015);
  check.set_verdict(
      "consistent: 0.1% of 1000 wall cells contradicted both ways (limit 5.0%); 0 areas of 5 m "
      "contradict themselves (limit 2; an area: 20% and 20 cells; worst 0.0%)");
  check.set_nodes(100);
  check.set_submaps(4);
  check.set_resolution(0.05);
  return check;
}

bool Near(const cv::Vec3b& bgr, int b, int g, int r) {
  return std::abs(bgr[0] - b) <= 10 && std::abs(bgr[1] - g) <= 10 && std::abs(bgr[2] - r) <= 10;
}

class MapCheckTest : public ::waymark::testing::FakeSlamCliTest {
 protected:
  CliResult Replay(const std::string& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"slam", "replay", WriteLog(20), "--out",
                                     (dir_.path() / out).string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return Run(args);
  }

  nlohmann::json Summary(const std::string& out) const {
    return nlohmann::json::parse(ReadFile(dir_.path() / out / "summary.json"));
  }

  static std::string ReadFile(const std::filesystem::path& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
};

TEST_F(MapCheckTest, AFinalMapThatContradictsItselfIsWarnedAboutDrawnAndExitsThree) {
  server_.service().set_occupancy_grid(FreeGrid());
  server_.service().set_map_self_check(FoldedCheck());
  CliResult r = Replay("folded");
  EXPECT_EQ(r.code, kExitInconsistentMap) << r.err;
  EXPECT_EQ(r.code, 3);  // the documented number
  EXPECT_THAT(r.out, HasSubstr("map self-check: contradicts itself: 7.9%"));
  EXPECT_THAT(r.err, HasSubstr("WARNING: the final map contradicts itself: 2 areas"));
  EXPECT_THAT(r.err, HasSubstr("x -0.15..-0.05, y 0.4..0.5 m (45%)"));
  EXPECT_THAT(r.err, HasSubstr("occupancy.png outlines them in orange"));
  EXPECT_THAT(r.err, HasSubstr("exit code 3 (--allow-inconsistent-map"));

  // Everything was written all the same, the verdict in summary.json.
  const nlohmann::json summary = Summary("folded");
  const nlohmann::json& check = summary["self_check"];
  EXPECT_EQ(check["consistent"], false);
  EXPECT_EQ(check["final_map"], true);
  EXPECT_EQ(check["fails_replay"], true);
  EXPECT_EQ(check["areas_contradicting"], 2);
  EXPECT_DOUBLE_EQ(check["contradicted_fraction"].get<double>(), 0.079);
  ASSERT_EQ(check["worst_areas"].size(), 2u);
  EXPECT_DOUBLE_EQ(check["worst_areas"][0]["contradicted_fraction"].get<double>(), 0.45);
  EXPECT_DOUBLE_EQ(check["worst_areas"][0]["min"][0].get<double>(), -0.15);
  EXPECT_EQ(check["contradicting_cells"], 1);
  EXPECT_THAT(check["verdict"].get<std::string>(), HasSubstr("contradicts itself"));

  // occupancy.png: the contradicting cell red, the failing area's outline orange, free cells white.
  const cv::Mat picture = cv::imread((dir_.path() / "folded" / "occupancy.png").string());
  ASSERT_EQ(picture.cols, 512);
  ASSERT_EQ(picture.rows, 256);
  EXPECT_TRUE(Near(picture.at<cv::Vec3b>(PixelOf(0.125, 0.425)), 30, 30, 230));
  EXPECT_TRUE(Near(picture.at<cv::Vec3b>(PixelOf(-0.15, 0.45)), 0, 140, 255));
  EXPECT_TRUE(Near(picture.at<cv::Vec3b>(PixelOf(0.175, 0.375)), 254, 254, 254));
}

TEST_F(MapCheckTest, AllowInconsistentMapWarnsButExitsZero) {
  server_.service().set_map_self_check(FoldedCheck());
  CliResult r = Replay("allowed", {"--allow-inconsistent-map"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("WARNING: the final map contradicts itself"));
  EXPECT_THAT(r.err, HasSubstr("--allow-inconsistent-map: exit code 0"));
  EXPECT_EQ(Summary("allowed")["self_check"]["fails_replay"], false);
}

TEST_F(MapCheckTest, AMapCutShortByMaxScansIsStillTheSessionsFinalMap) {
  server_.service().set_map_self_check(FoldedCheck());
  EXPECT_EQ(Replay("short", {"--max-scans", "5"}).code, kExitInconsistentMap);
}

TEST_F(MapCheckTest, AConsistentMapExitsZeroWithoutAWarning) {
  server_.service().set_occupancy_grid(FreeGrid());
  server_.service().set_map_self_check(ConsistentCheck());
  CliResult r = Replay("consistent");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("map self-check: consistent: 0.1%"));
  EXPECT_THAT(r.err, Not(HasSubstr("WARNING")));
  const nlohmann::json summary = Summary("consistent");
  EXPECT_EQ(summary["self_check"]["consistent"], true);
  EXPECT_EQ(summary["self_check"]["fails_replay"], false);
  EXPECT_TRUE(summary["self_check"]["worst_areas"].empty());
}

TEST_F(MapCheckTest, AMapWithoutACheckIsNotJudged) {
  // A server older than the self-check, or a session that keeps no scans: GetMap has none.
  CliResult r = Replay("none");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, Not(HasSubstr("self-check")));
  EXPECT_TRUE(Summary("none")["self_check"].is_null());
}

TEST_F(MapCheckTest, ListShowsEachClosedSessionsVerdict) {
  server_.service().set_map_self_check(FoldedCheck());
  ASSERT_EQ(Replay("a").code, kExitInconsistentMap);
  server_.service().set_map_self_check(ConsistentCheck());
  ASSERT_EQ(Replay("b").code, 0);
  CliResult list = Run({"slam", "list"});
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_THAT(list.out, HasSubstr("map check"));
  EXPECT_THAT(list.out, HasSubstr("CONTRADICTS: 2 areas, 7.9%"));
  EXPECT_THAT(list.out, HasSubstr("consistent (0.1%)"));
  CliResult json = Run({"--json", "slam", "list"});
  ASSERT_EQ(json.code, 0) << json.err;
  const nlohmann::json sessions = json.Json()["sessions"];
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_EQ(sessions[0]["self_check"]["consistent"], false);
  EXPECT_EQ(sessions[0]["self_check"]["areas_contradicting"], 2);
  EXPECT_TRUE(sessions[0]["self_check"]["contradicting_cells"].empty());  // GetMap has them
  EXPECT_EQ(sessions[1]["self_check"]["consistent"], true);
}

}  // namespace
}  // namespace waymark::cli

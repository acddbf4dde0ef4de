// `waymark slam replay` against the in-memory fake SlamService when things are not as they should
// be: logs with broken stamps (--restamp), time spans that give no real-time factor, a replay
// stopped by Ctrl-C or by a broken stream, a server that cannot be asked afterwards, and --out
// naming a picture.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "client/cli/cli.h"
#include "client/datasets/tum_trajectory.h"
#include "client/sessions/replay_report.h"
#include "client/sessions/slam_replay.h"
#include "tests/client/carmen_test_log.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::MakeLog;
using waymark::testing::MakeLogWithStamps;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

class SlamReplayTest : public ::testing::Test {
 protected:
  CliResult Run(std::vector<std::string> args) {
    return RunWaymark(server_.address(), std::move(args));
  }

  std::string WriteLog(const std::string& text, const std::string& name = "test.clf") {
    const auto path = dir_.path() / name;
    std::ofstream(path) << text;
    return path.string();
  }

  // RunSlamReplay in process with a stop request after `scans_before_stop` scans were sent.
  CliResult ReplayStoppedAfter(const std::string& log, int scans_before_stop,
                               const std::filesystem::path& out) {
    std::ostringstream out_text, err_text;
    CommandContext context{GlobalOptions{}, out_text, err_text};
    context.globals.server = server_.address();
    context.globals.json = true;
    ReplayArgs args;
    args.log = log;
    args.out_dir = out.string();
    int asked = 0;  // asked once before each scan: the first `scans_before_stop` go out
    CliResult result;
    result.code =
        RunSlamReplay(context, args, [&asked, scans_before_stop] { return asked++ >= scans_before_stop; });
    result.out = out_text.str();
    result.err = err_text.str();
    return result;
  }

  v1::Session::State StateOf(const std::string& id) {
    CliResult list = Run({"--json", "slam", "list"});
    const nlohmann::json sessions = list.Json()["sessions"];
    for (const auto& session : sessions) {
      if (session["session_id"] == id) {
        return session["state"] == "closed" ? v1::Session::CLOSED : v1::Session::OPEN;
      }
    }
    ADD_FAILURE() << "session " << id << " not listed: " << list.out;
    return v1::Session::STATE_UNSPECIFIED;
  }

  ScopedTempDir dir_;
  FakeSlamServer server_;
};

int PoseLines(const std::filesystem::path& path) {
  auto poses = ReadTumFile(path);
  EXPECT_TRUE(poses.ok()) << poses.status();
  return poses.ok() ? static_cast<int>(poses->size()) : -1;
}

TEST_F(SlamReplayTest, MostStampsSkippedIsALoudFailureThatPointsAtRestamp) {
  // orebro and freiburg-campus: every FLASER stamp is 0.
  const std::string log = WriteLog(MakeLogWithStamps(std::vector<double>(40, 0.0)));
  CliResult r = Run({"--json", "slam", "replay", log, "--out", (dir_.path() / "o").string()});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("WARNING: 39 of 40 laser lines (97.5%) were skipped"));
  EXPECT_THAT(r.err, HasSubstr("39 repeat the stamp 0"));
  EXPECT_THAT(r.err, HasSubstr("only 1 scans were used"));
  EXPECT_THAT(r.err, HasSubstr("--restamp"));
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["scans"], 1);
  EXPECT_EQ(json["skipped_stamps"], 39);
  EXPECT_EQ(json["stamps_broken"], true);
  EXPECT_TRUE(json["realtime_factor"].is_null());
  EXPECT_THAT(json["realtime_factor_note"].get<std::string>(), HasSubstr("not meaningful"));
  EXPECT_EQ(json["partial"], false);  // the log was read to its end; it is the stamps that failed
  EXPECT_EQ(PoseLines(dir_.path() / "o" / "trajectory.txt"), 1);  // the outputs are still written

  CliResult human = Run({"slam", "replay", log, "--out", (dir_.path() / "h").string()});
  EXPECT_EQ(human.code, 1);
  EXPECT_THAT(human.out, HasSubstr("no real-time factor (the log's time span is not meaningful: "
                                   "most stamps were skipped)"));
  EXPECT_THAT(human.out, Not(HasSubstr("real-time factor 0")));
}

TEST_F(SlamReplayTest, OdometryWarnsAboutBrokenStampsToo) {
  const std::string log = WriteLog(MakeLogWithStamps(std::vector<double>(10, 7.0)));
  const auto out = dir_.path() / "odom.txt";
  CliResult r = Run({"slam", "odometry", log, "--out", out.string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("9 of 10 laser lines"));
  CliResult restamped =
      Run({"--json", "slam", "odometry", log, "--out", out.string(), "--restamp", "--rate", "4"});
  ASSERT_EQ(restamped.code, 0) << restamped.err;
  EXPECT_EQ(restamped.Json()["poses"], 10);
  EXPECT_EQ(restamped.Json()["stamps"], "synthesized");
  auto poses = ReadTumFile(out);
  ASSERT_TRUE(poses.ok());
  EXPECT_DOUBLE_EQ(poses->back().stamp, 9 / 4.0);
}

// --speed paces the replay at the log's pace times the factor (here far above the machine's:
// the pace is not what this asserts) and sends every scan as a full-speed replay does.
TEST_F(SlamReplayTest, SpeedSendsEveryScanAndRefusesAFactorThatIsNotPositive) {
  const std::string log = WriteLog(MakeLogWithStamps({0.0, 0.5, 1.0, 1.5, 2.0}));
  CliResult r = Run({"--json", "slam", "replay", log, "--speed", "1000", "--out",
                     (dir_.path() / "o").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["scans"], 5);
  const std::vector<double> sent = server_.service().scan_stamps();
  ASSERT_EQ(sent.size(), 5u);
  for (size_t i = 0; i < sent.size(); ++i) EXPECT_DOUBLE_EQ(sent[i], 0.5 * i);
  for (const char* bad : {"0", "-2"}) {
    CliResult refused = Run({"slam", "replay", log, "--speed", bad});
    EXPECT_NE(refused.code, 0) << bad;
    EXPECT_NE(refused.err.find("--speed"), std::string::npos) << refused.err;
  }
}

TEST_F(SlamReplayTest, RestampSendsEveryLineInFileOrderAtTheRate) {
  // infinite-corridor: a few stamps going backwards, then 4294967295 over and over.
  std::vector<double> stamps = {-0.4, -0.9, -1.3};
  stamps.resize(30, 4294967295.0);
  const std::string log = WriteLog(MakeLogWithStamps(stamps));
  CliResult r = Run({"--json", "slam", "replay", log, "--restamp", "--rate", "2", "--out",
                     (dir_.path() / "o").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["scans"], 30);
  EXPECT_EQ(json["skipped_stamps"], 0);
  EXPECT_EQ(json["stamps"], "synthesized");
  EXPECT_EQ(json["restamp_rate_hz"], 2.0);
  EXPECT_DOUBLE_EQ(json["log_duration_s"].get<double>(), 29 / 2.0);
  EXPECT_TRUE(json["realtime_factor"].is_number());
  const std::vector<double> sent = server_.service().scan_stamps();
  ASSERT_EQ(sent.size(), 30u);
  for (size_t i = 0; i < sent.size(); ++i) EXPECT_DOUBLE_EQ(sent[i], i / 2.0);
  // File order, not stamp order: the odometry x grows by 0.1 m per line.
  auto poses = ReadTumFile(dir_.path() / "o" / "trajectory.txt");
  ASSERT_TRUE(poses.ok());
  EXPECT_NEAR((*poses)[1].pose.x, 0.1, 1e-9);

  CliResult human = Run({"slam", "replay", log, "--restamp", "--out",
                         (dir_.path() / "h").string()});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, HasSubstr("stamps synthesized from the log's line order at 5 Hz"));
  EXPECT_THAT(human.out, HasSubstr("log 5.8 s (synthesized) replayed in"));
  EXPECT_EQ(human.err.find("WARNING"), std::string::npos) << human.err;
}

TEST_F(SlamReplayTest, RateNeedsRestamp) {
  const std::string log = WriteLog(MakeLog(5));
  CliResult r = Run({"slam", "replay", log, "--rate", "2"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("--restamp"));
  EXPECT_NE(Run({"slam", "replay", log, "--restamp", "--rate", "0"}).code, 0);
}

TEST_F(SlamReplayTest, AJumpInTheStampsGivesNoRealTimeFactor) {
  // Twenty good stamps, then one far in the future: nothing is skipped, but the span is no clock.
  std::vector<double> stamps;
  for (int i = 0; i < 20; ++i) stamps.push_back(10.0 + i);
  stamps.push_back(4294967295.0);
  const std::string log = WriteLog(MakeLogWithStamps(stamps));
  CliResult r = Run({"slam", "replay", log, "--out", (dir_.path() / "o").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("21 scans processed"));
  EXPECT_THAT(r.out, HasSubstr("no real-time factor"));
  EXPECT_THAT(r.out, HasSubstr("between two consecutive scans"));
  EXPECT_THAT(r.out, Not(HasSubstr("real-time factor 4")));
}

TEST_F(SlamReplayTest, StopRequestClosesTheSessionAndWritesPartialOutputs) {
  const std::string log = WriteLog(MakeLog(100));
  const auto out = dir_.path() / "o";
  CliResult r = ReplayStoppedAfter(log, 30, out);
  EXPECT_EQ(r.code, kExitInterrupted) << r.err;
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["partial"], true);
  EXPECT_EQ(json["stopped"], "interrupted");
  EXPECT_EQ(json["scans_sent"], 30);
  EXPECT_EQ(json["scans"], 30);  // every scan sent was answered before the session was closed
  EXPECT_EQ(json["session_closed"], true);
  EXPECT_EQ(server_.service().scans_received(), 30);
  EXPECT_EQ(PoseLines(out / "trajectory.txt"), 30);
  EXPECT_FALSE(cv::imread((out / "map.png").string()).empty());
  EXPECT_THAT(ReadAll(out / "map.svg"), HasSubstr("partial: interrupted"));
  const nlohmann::json summary = nlohmann::json::parse(ReadAll(out / "summary.json"));
  EXPECT_EQ(summary["partial"], true);
  EXPECT_EQ(summary["scans_sent"], 30);
  EXPECT_EQ(StateOf(json["session_id"].get<std::string>()), v1::Session::CLOSED);
}

TEST_F(SlamReplayTest, StopRequestSaysWhatWasDoneForPeople) {
  std::ostringstream out_text, err_text;
  CommandContext context{GlobalOptions{}, out_text, err_text};
  context.globals.server = server_.address();
  ReplayArgs args;
  args.log = WriteLog(MakeLog(50));
  args.out_dir = (dir_.path() / "o").string();
  int asked = 0;
  EXPECT_EQ(RunSlamReplay(context, args, [&asked] { return asked++ >= 12; }), kExitInterrupted);
  EXPECT_THAT(out_text.str(), HasSubstr("interrupted after 12 scans sent, 12 answered: the "
                                        "outputs are partial"));
  EXPECT_THAT(out_text.str(), HasSubstr("session s1 closed"));
}

TEST_F(SlamReplayTest, ABrokenStreamStillClosesTheSessionAndWritesWhatWasAnswered) {
  server_.service().set_break_streams_after(20);
  const std::string log = WriteLog(MakeLog(60));
  const auto out = dir_.path() / "o";
  CliResult r = Run({"--json", "slam", "replay", log, "--out", out.string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("UNAVAILABLE"));
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["partial"], true);
  EXPECT_EQ(json["stopped"], "error");
  EXPECT_THAT(json["error"].get<std::string>(), HasSubstr("stream broken on purpose"));
  EXPECT_EQ(json["scans"], 20);
  EXPECT_EQ(json["session_closed"], true);
  EXPECT_EQ(json["trajectory_source"], "server");
  EXPECT_EQ(PoseLines(out / "trajectory.txt"), 20);
  EXPECT_EQ(nlohmann::json::parse(ReadAll(out / "summary.json"))["partial"], true);
  EXPECT_EQ(StateOf(json["session_id"].get<std::string>()), v1::Session::CLOSED);
}

TEST_F(SlamReplayTest, WhenTheServerCannotBeAskedTheSessionIsNamedAsLeftOpen) {
  server_.service().set_break_streams_after(15);
  server_.service().set_session_calls_fail(grpc::StatusCode::UNAVAILABLE);
  const std::string log = WriteLog(MakeLog(40));
  const auto out = dir_.path() / "o";
  CliResult r = Run({"slam", "replay", log, "--out", out.string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.out, HasSubstr("stopped by an error after"));
  EXPECT_THAT(r.out, HasSubstr("session s1 was left open: close it with `waymark slam close s1`"));
  EXPECT_THAT(r.out, HasSubstr("`waymark slam delete s1 --force`"));
  EXPECT_THAT(r.out, HasSubstr("the map pictures show no segments: GetMap: UNAVAILABLE"));
  // The trajectory comes from the answers the stream got.
  EXPECT_EQ(PoseLines(out / "trajectory.txt"), 15);
  const nlohmann::json summary = nlohmann::json::parse(ReadAll(out / "summary.json"));
  EXPECT_EQ(summary["session_closed"], false);
  EXPECT_THAT(summary["trajectory_source"].get<std::string>(), HasSubstr("stream answers"));
  EXPECT_THAT(summary["close_error"].get<std::string>(), HasSubstr("UNAVAILABLE"));
}

// Issue 35: the progress bar follows the scans sent, of the scans in the log: the reader reads
// ahead (a compressed log may be read whole after a few hundred scans), so its bytes are no
// measure of progress ("819/819 KiB of log" after 234 of 7374 scans).
TEST_F(SlamReplayTest, ProgressCountsScansSentOfTheScansInTheLog) {
  // 64 scans as fast as they go; 20 at the log's pace (0.2 s apart: 4 s).
  for (const auto& [scans, extra] : std::vector<std::pair<int, std::vector<std::string>>>{
           {64, {}}, {20, {"--realtime"}}}) {
    SCOPED_TRACE(scans);
    const std::string log = WriteLog(MakeLog(scans), "progress" + std::to_string(scans) + ".clf");
    std::vector<std::string> args = {"waymark", "--server", server_.address(),
                                     "--json",  "slam",     "replay",
                                     log,       "--out",    (dir_.path() / "p").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<const char*> argv;
    for (const std::string& arg : args) argv.push_back(arg.c_str());
    std::ostringstream out, err;
    ASSERT_EQ(RunCli(static_cast<int>(argv.size()), argv.data(), out, err, /*err_is_tty=*/true),
              0)
        << err.str();
    const int sent = nlohmann::json::parse(out.str())["scans_sent"].get<int>();
    EXPECT_EQ(err.str().find("KiB"), std::string::npos) << err.str();
    // Every draw is "k/TOTAL scans" with TOTAL the log's scans.
    const std::string total = "/" + std::to_string(sent) + " scans";
    EXPECT_EQ(sent, scans);
    size_t draws = 0;
    for (size_t at = err.str().find('\r'); at != std::string::npos;
         at = err.str().find('\r', at + 1)) {
      ++draws;
      const std::string line = err.str().substr(at + 1, err.str().find_first_of("\r\n", at + 1) - at - 1);
      EXPECT_THAT(line, HasSubstr(total)) << line;
    }
    EXPECT_GE(draws, 1u);
    EXPECT_THAT(err.str(), HasSubstr(std::to_string(sent) + total + ": "));
  }
}

TEST_F(SlamReplayTest, OutNamingAPictureWritesOnlyThatPicture) {
  const std::string log = WriteLog(MakeLog(20));
  for (const std::string name : {"map.svg", "Map.PNG"}) {
    SCOPED_TRACE(name);
    const auto folder = dir_.path() / ("run-" + name);
    std::filesystem::create_directories(folder);
    const auto picture = folder / name;
    CliResult r = Run({"slam", "replay", log, "--out", picture.string()});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(std::filesystem::is_regular_file(picture));
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(folder),
                            std::filesystem::directory_iterator()),
              1);  // nothing else
    EXPECT_THAT(r.out, HasSubstr("wrote " + picture.string() + "\n"));
  }
  EXPECT_FALSE(cv::imread((dir_.path() / "run-Map.PNG" / "Map.PNG").string()).empty());
  EXPECT_THAT(ReadAll(dir_.path() / "run-map.svg" / "map.svg"), HasSubstr("<svg"));
}

TEST(ReplayReportTest, SpanProblems) {
  StampSpan span;
  EXPECT_EQ(SpanProblem(span, false), "fewer than two scans");
  span.Add(1.0);
  span.Add(2.0);
  EXPECT_EQ(SpanProblem(span, false), std::nullopt);
  EXPECT_EQ(SpanProblem(span, true), "most stamps were skipped");
  span.Add(2.0 + kMaxPlausibleScanGapS + 1);
  EXPECT_THAT(SpanProblem(span, false).value_or(""), HasSubstr("between two consecutive scans"));
}

}  // namespace
}  // namespace waymark::cli

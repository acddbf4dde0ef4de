// `waymark vo run` on a stream that breaks mid-run (issue 15: it died with "keepalive watchdog
// timeout" after 50 of 140 frames): the fake SlamService ends every stream after a few frames, and
// the run reopens the stream on the same session, resends from the first frame not answered and
// completes with every frame answered once.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;
namespace fs = std::filesystem;

constexpr int kFrames = 12;

// 1/8 s apart: exact in binary and in rgb.txt, so the server's stamps compare equal.
double Stamp(int i) { return 1.0 + 0.125 * i; }

// A TUM folder of kFrames real 64x48 PNGs.
class VoResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream list(dir_.path() / "rgb.txt");
    for (int i = 0; i < kFrames; ++i) {
      const std::string name = "rgb/" + std::to_string(i) + ".png";
      waymark::testing::WriteImage(dir_.Make(name), 64, 48, cv::Scalar(10 * i, 20, 30));
      list << Stamp(i) << " " << name << "\n";
    }
  }
  CliResult Run() {
    return RunWaymark(server_.address(),
                      {"--json", "vo", "run", dir_.path().string(), "--fx", "50", "--fy", "50",
                       "--cx", "32", "--cy", "24", "--out", (dir_.path() / "out").string()});
  }
  // Poses in the run's trajectory.txt.
  int TrajectoryLines() const {
    std::ifstream in(dir_.path() / "out" / "trajectory.txt");
    int lines = 0;
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line[0] != '#') ++lines;
    }
    return lines;
  }

  ScopedTempDir dir_;
  FakeSlamServer server_;
};

TEST_F(VoResumeTest, ABrokenStreamIsReopenedAndEveryFrameIsAnsweredOnce) {
  server_.service().set_break_streams_after(5);  // frames 6 and 11 break their streams
  const CliResult r = Run();
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json summary = r.Json();
  EXPECT_EQ(summary["processed"], kFrames);
  EXPECT_EQ(summary["rejected"], 0);
  EXPECT_EQ(summary["stream_reconnects"], 2);
  EXPECT_EQ(summary["answers_lost"], 0);
  EXPECT_EQ(server_.service().streams_opened(), 3);
  EXPECT_THAT(r.err, HasSubstr("fake: stream broken on purpose"));
  EXPECT_THAT(r.err, HasSubstr("resending from the first frame not answered"));
  // The server got each frame once, in order: the resends started where the answers stopped.
  std::vector<double> expected;
  for (int i = 0; i < kFrames; ++i) expected.push_back(Stamp(i));
  EXPECT_EQ(server_.service().scan_stamps(), expected);
  EXPECT_EQ(TrajectoryLines(), kFrames);
}

TEST_F(VoResumeTest, ASessionThatResumedFromAnOlderCheckpointIsReported) {
  server_.service().set_break_streams_after(5);
  server_.service().set_rollback_on_break(2);  // the "server" lost frames 3..5 with the break
  const CliResult r = Run();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("warning: session s1 resumed from a checkpoint 3 frames / 0.4 s "
                               "behind this run"));
  // The answers already received stay in the run's outputs.
  EXPECT_EQ(r.Json()["processed"], kFrames);
  EXPECT_EQ(TrajectoryLines(), kFrames);
}

// A server that is shutting down refuses frames with UNAVAILABLE before it ends the stream: those
// are not answers, and go again on the next stream (seen with the real server: frames 62-66 of a
// Bonn run were left "rejected: the server is shutting down").
TEST_F(VoResumeTest, FramesRefusedForNowAreSentAgainOnTheNextStream) {
  server_.service().set_refuse_first_stream_after(5);
  const CliResult r = Run();
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json summary = r.Json();
  EXPECT_EQ(summary["processed"], kFrames);
  EXPECT_EQ(summary["rejected"], 0);
  EXPECT_EQ(summary["stream_reconnects"], 1);
  EXPECT_THAT(r.err, HasSubstr("fake: the server is shutting down"));
  std::vector<double> expected;
  for (int i = 0; i < kFrames; ++i) expected.push_back(Stamp(i));
  EXPECT_EQ(server_.service().scan_stamps(), expected);
  EXPECT_EQ(TrajectoryLines(), kFrames);
}

TEST_F(VoResumeTest, NoServerAtAllIsReportedWithTheAddressDialled) {
  const CliResult r = RunWaymark("127.0.0.1:1", {"vo", "run", dir_.path().string(), "--fx", "50",
                                                 "--fy", "50", "--cx", "32", "--cy", "24", "--out",
                                                 (dir_.path() / "out").string()});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("is the server running at 127.0.0.1:1?"));
}

}  // namespace
}  // namespace waymark::cli

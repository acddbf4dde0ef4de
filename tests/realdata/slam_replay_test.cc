// End to end through the real server: `waymark slam replay` of the first 400 scans of the ACES log
// (../shared/data/laser, read in place; skips when absent) against a waymark-server started for
// the test, then the JSON summary, the trajectory file and the map pictures are checked. And the
// first 3000 scans of the Intel log, where the robot goes round the building's loop: loop
// closure, the map files, import-map and localization on the imported map.

#include <gtest/gtest.h>
#include <signal.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "tests/support/server_process.h"

namespace waymark {
namespace {

using testing::ServerProcess;

std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `command`, returns its exit code and stdout (stderr goes to the test's stderr).
int RunCommand(const std::string& command, std::string* out) {
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out->append(buffer.data(), n);
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(SlamReplayRealData, FirstScansOfAcesThroughTheRealServer) {
  const std::filesystem::path log =
      std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "laser" / "aces" / "aces.clf.bz2";
  if (!std::filesystem::exists(log)) GTEST_SKIP() << "no " << log << " (../shared absent)";

  const std::string dir = testing::MakeTempDir("waymark-slam-replay");
  auto server = ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db");
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string out_dir = dir + "/out";
  const std::string cli = std::string(WAYMARK_BINARY_DIR) + "/bin/waymark";
  std::string out;
  const int code = RunCommand(cli + " --server " + (*server)->address() +
                                  " slam replay --max-scans 400 --json --out " + out_dir + " " +
                                  log.string(),
                              &out);
  ASSERT_EQ(code, 0) << out << "\nserver log:\n" << (*server)->Log();

  const nlohmann::json json = nlohmann::json::parse(out);
  EXPECT_EQ(json["scans_sent"], 400);
  EXPECT_EQ(json["rejected"], 0);
  EXPECT_EQ(json["queue_full"], 0);
  EXPECT_EQ(json["malformed_lines"], 0);
  // Every scan is answered; some may be skipped for too little motion.
  EXPECT_GT(json["scans"].get<int>(), 0);
  EXPECT_LE(json["scans"].get<int>(), 400);
  EXPECT_GT(json["segments"].get<int>(), 5);
  EXPECT_GT(json["log_duration_s"].get<double>(), 30);
  EXPECT_GT(json["processing_s"].get<double>(), 0);
  // Faster or slower than real time depends on the machine: only that it was measured.
  EXPECT_GT(json["realtime_factor"].get<double>(), 0);
  EXPECT_FALSE(json["session_id"].get<std::string>().empty());

  // trajectory.txt: one TUM pose per trajectory entry, within the log's stamps.
  std::istringstream lines(ReadText(out_dir + "/trajectory.txt"));
  int poses = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    ASSERT_TRUE(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw) << line;
    EXPECT_GE(t, 70.0);
    EXPECT_NEAR(qz * qz + qw * qw, 1.0, 1e-6);
    ++poses;
  }
  EXPECT_EQ(poses, json["trajectory_poses"].get<int>());
  EXPECT_GT(poses, 0);

  const std::string svg = ReadText(out_dir + "/map.svg");
  EXPECT_EQ(Count(svg, "class=\"segment "), json["segments"].get<int>());
  EXPECT_FALSE(cv::imread(out_dir + "/map.png").empty());
  EXPECT_TRUE(std::filesystem::exists(out_dir + "/summary.json"));

  EXPECT_EQ((*server)->Stop(SIGTERM), 0) << (*server)->Log();
  std::filesystem::remove_all(dir);
}

// The TUM poses of a trajectory file by stamp (rounded to 0.1 ms).
std::map<long long, std::pair<double, double>> ReadPositions(const std::string& path) {
  std::map<long long, std::pair<double, double>> out;
  std::istringstream lines(ReadText(path));
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y;
    if (fields >> t >> x >> y) out[std::llround(t * 1e4)] = {x, y};
  }
  return out;
}

TEST(SlamReplayRealData, IntelsFirstLoopsCloseAndItsMapLocalizesTheRobot) {
  const std::filesystem::path data = std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "laser";
  const std::filesystem::path log = data / "intel" / "intel.clf.bz2";
  const std::filesystem::path relations = data / "intel" / "intel.relations";
  if (!std::filesystem::exists(log)) GTEST_SKIP() << "no " << log << " (../shared absent)";

  const std::string dir = testing::MakeTempDir("waymark-intel-loops");
  auto server = ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db");
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string cli =
      std::string(WAYMARK_BINARY_DIR) + "/bin/waymark --server " + (*server)->address();
  const std::string out_dir = dir + "/map";
  std::string out;
  ASSERT_EQ(RunCommand(cli + " --json slam replay --max-scans 3000 --out " + out_dir + " " +
                           log.string(),
                       &out),
            0)
      << out << "\nserver log:\n" << (*server)->Log();
  const nlohmann::json mapped = nlohmann::json::parse(out);
  // Measured (2026-12-02): 166 loop closures; the paper's EKF alone is at 0.43 m mean on these
  // relations, with loop closure 0.028 m. The floors leave room, not a second method.
  EXPECT_GT(mapped["loop_closures"].get<int>(), 50);
  std::string scored;
  ASSERT_EQ(RunCommand(std::string(WAYMARK_BINARY_DIR) + "/bin/waymark --json eval relations " +
                           out_dir + "/trajectory.txt " + relations.string(),
                       &scored),
            0)
      << scored;
  const nlohmann::json metric = nlohmann::json::parse(scored);
  EXPECT_GT(metric["relations_used"].get<int>(), 400);
  EXPECT_LT(metric["trans_abs_mean"].get<double>(), 0.06) << scored;

  // The map a navigation stack takes, and back into the server.
  for (const char* file : {"map.pgm", "map.yaml", "occupancy.png"}) {
    EXPECT_TRUE(std::filesystem::exists(out_dir + "/" + file)) << file;
  }
  std::string imported;
  ASSERT_EQ(RunCommand(cli + " --json slam import-map " + out_dir + "/map.yaml", &imported), 0)
      << imported;
  const std::string map_id = nlohmann::json::parse(imported)["session_id"].get<std::string>();

  // The same scans again, from an unknown start, on the session's map and on the imported one:
  // found, then tracked. Errors against the mapping run's trajectory (the same map frame).
  const auto truth = ReadPositions(out_dir + "/trajectory.txt");
  struct Errors {
    double mean = 0;
    int compared = 0, far = 0, localized = 0;
  };
  const auto localize_on = [&](const std::string& map, const std::string& name) {
    Errors errors;
    const std::string loc_dir = dir + "/" + name;
    std::string text;
    EXPECT_EQ(RunCommand(cli + " --json slam replay --max-scans 3000 --localize-on " + map +
                             " --out " + loc_dir + " " + log.string(),
                         &text),
              0)
        << text;
    if (text.empty()) return errors;
    errors.localized = nlohmann::json::parse(text)["localization"]["localized_scans"].get<int>();
    for (const auto& [stamp, p] : ReadPositions(loc_dir + "/trajectory.txt")) {
      const auto it = truth.find(stamp);
      if (it == truth.end()) continue;
      const double e = std::hypot(p.first - it->second.first, p.second - it->second.second);
      errors.mean += e;
      errors.far += e > 0.5 ? 1 : 0;
      ++errors.compared;
    }
    if (errors.compared > 0) errors.mean /= errors.compared;
    return errors;
  };
  // Measured (engine, same scans): first fix at scan 147 (29 s), 2853 of 3000 localized; on the
  // session's map 0.020 m mean and no pose off by 0.5 m; on the exported grid 0.057 m and 10.
  const Errors on_session = localize_on(mapped["session_id"].get<std::string>(), "on-session");
  EXPECT_GT(on_session.localized, 2500);
  ASSERT_GT(on_session.compared, 2900);
  EXPECT_LT(on_session.mean, 0.06);
  EXPECT_EQ(on_session.far, 0);
  const Errors on_grid = localize_on(map_id, "on-grid");
  EXPECT_GT(on_grid.localized, 2500);
  ASSERT_GT(on_grid.compared, 2900);
  EXPECT_LT(on_grid.mean, 0.15);
  EXPECT_LT(on_grid.far, 60);  // 2 %

  EXPECT_EQ((*server)->Stop(SIGTERM), 0) << (*server)->Log();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace waymark

// waymark-failover-bench: robots streaming SLAM sessions over a fleet of servers on one
// PostgreSQL database, and one server killed (issue 19).
//
//   waymark-failover-bench --postgres postgresql://USER@HOST:PORT/postgres
//                          [--robots 20] [--servers 3] [--trials 20] [--lease 3]
//
// Each trial: a fresh database, `--servers` waymark-server processes, `--robots` simulated robots
// (one thread each, a SlamClient on "A,B,C" as `waymark robot --server A,B,C` would have),
// each creating a session and streaming an odometry + scan pair every 50 ms. After 3 s the server
// holding the most sessions is SIGKILLed. For the robots it held: the time from the kill until
// their stream is served again by another server, and the scans lost (answered before the kill
// but not in the checkpoint the session resumed from). For the others: whether their streams
// went on without a break. Writes failover_bench.json to --out.

#include <fmt/format.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <grpcpp/grpcpp.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_split.h"
#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "storage/postgres/pg_admin.h"
#include "tests/service/slam_test_world.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::bench {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1) + 0.5)];
}

struct RobotResult {
  std::string session;
  std::string first_server;  // where its first served stream ran (the stream's peer)
  int breaks = 0;            // streams that ended before the robot stopped
  double back_after_s = -1;  // kill -> first answered scan on a new stream (broken robots)
  int64_t lost = 0;          // answered scans the resumed session did not hold
  uint64_t answered = 0;     // the session's count in the last answer the robot had
};

// One robot: creates its session, streams until `stop`, reopening broken streams. `killed_at`
// is read after a break to time the recovery.
void Robot(int index, const std::string& fleet, const std::atomic<bool>& stop,
           const std::atomic<int64_t>& killed_at_ns, RobotResult& result) {
  client::SlamClientOptions options;
  options.connect = [](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address));
  };
  client::SlamClient slam(client::MakeChannel(fleet), options);
  absl::StatusOr<v1::Session> session =
      slam.CreateSession(testing::TestSessionRequest(fmt::format("robot-{}", index)));
  if (!session.ok()) {
    std::cerr << "robot " << index << ": " << session.status() << "\n";
    return;
  }
  result.session = session->session_id();
  uint64_t answered = 0;  // the session's count in the last answer
  int step = 0;
  bool broken = false;
  while (!stop) {
    std::atomic<uint64_t> last{0};
    std::unique_ptr<client::SensorStream> stream = slam.StreamSensorData(
        result.session, client::kDefaultScanWindow, [&last](const v1::SlamUpdate& u) {
          if (!u.has_rejection() && u.scans_processed() > 0) last = u.scans_processed();
        });
    absl::StatusOr<v1::StreamStart> start = stream->Hello(absl::Seconds(10));
    if (!start.ok()) {
      stream->Finish().IgnoreError();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      continue;
    }
    if (broken) {
      result.lost +=
          static_cast<int64_t>(answered) - static_cast<int64_t>(start->scans_processed());
      // The robot resends from the first scan the session does not hold.
      step = static_cast<int>(start->scans_processed());
    }
    bool first_answer_seen = false;
    while (!stop) {
      const double x = 0.01 * step;
      const v1::SensorData odom = testing::Odom(0, 1.0 + 0.05 * step, x, 0, 0);
      const v1::SensorData scan = testing::RoomScan(0, 1.0 + 0.05 * step, x, 0, 0);
      if (!stream->SendOdometry(odom.odometry()).ok() || !stream->SendScan(scan.scan()).ok()) {
        break;
      }
      ++step;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (last > 0) answered = last;
      if (broken && !first_answer_seen && last > start->scans_processed()) {
        first_answer_seen = true;
        result.back_after_s =
            std::chrono::duration<double>(Clock::now().time_since_epoch()).count() -
            killed_at_ns.load() / 1e9;
      }
    }
    const absl::Status ended = stream->Finish();
    if (last > 0) answered = last;
    result.answered = answered;
    if (stop) break;
    ++result.breaks;
    broken = true;
    (void)ended;
  }
}

// A fresh database, `servers` servers on it and `robots` robots streaming to them.
struct FleetRun {
  std::string db;
  std::vector<std::unique_ptr<testing::ServerProcess>> servers;
  std::atomic<bool> stop{false};
  std::atomic<int64_t> killed_at_ns{0};  // when a server was killed (kill trials)
  std::vector<RobotResult> results;
  std::vector<std::thread> robots;

  FleetRun(const std::string& postgres, int server_count, int robot_count, double lease) {
    auto fresh = storage::pg::RecreateDatabase(postgres, "waymark_failover_bench");
    if (!fresh.ok()) throw std::runtime_error(fresh.status().ToString());
    db = *fresh;
    std::string addresses;
    for (int s = 0; s < server_count; ++s) {
      auto started = testing::ServerProcess::Start(
          testing::ServerBinary(), db,
          {"--slam-checkpoint-scans", "5", "--slam-checkpoint-seconds", "0",
           "--session-lease-seconds", fmt::format("{}", lease), "--max-sessions", "64"});
      if (!started.ok()) throw std::runtime_error(started.status().ToString());
      addresses += (s ? "," : "") + (*started)->address();
      servers.push_back(*std::move(started));
    }
    results.resize(robot_count);
    for (int r = 0; r < robot_count; ++r) {
      robots.emplace_back(Robot, r, addresses, std::cref(stop), std::cref(killed_at_ns),
                          std::ref(results[r]));
    }
  }
  void StopRobots() {
    stop = true;
    for (std::thread& t : robots) t.join();
  }
};

// The scans each session's last checkpoint holds, by session id.
std::map<std::string, int64_t> StoredScans(const std::string& db) {
  std::map<std::string, int64_t> stored;
  auto rows = storage::pg::QueryText(
      db, "SELECT string_agg(id || ':' || scans_processed, ',') FROM slam_session");
  if (!rows.ok()) return stored;
  for (absl::string_view pair : absl::StrSplit(*rows, ',', absl::SkipEmpty())) {
    const size_t colon = pair.find(':');
    stored[std::string(pair.substr(0, colon))] = std::stoll(std::string(pair.substr(colon + 1)));
  }
  return stored;
}

// Enrolls views into database "restart" through the fleet until `stop`, as a mapper would, and
// counts the answers by code; `stored` gets the ids of the views answered STORED.
struct EnrollCounts {
  int ok = 0;
  int unavailable = 0;
  int other = 0;
  std::vector<int64_t> stored;
};
void Enroller(const std::string& fleet, const std::atomic<bool>& stop, EnrollCounts& counts) {
  auto stub = v1::CrossingService::NewStub(client::MakeChannel(fleet));
  for (int n = 0; !stop; ++n) {
    v1::EnrollViewRequest request;
    request.set_database("restart");
    request.set_crossing(fmt::format("c{}", n));
    request.set_heading_deg(0);
    request.set_create_crossing(true);
    request.mutable_image()->set_data(
        testing::EncodePng(testing::CropView(testing::MakePanorama(1000 + n), 0)));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::EnrollViewResponse response;
    const grpc::Status status = stub->EnrollView(&context, request, &response);
    if (status.ok()) {
      ++counts.ok;
      counts.stored.push_back(response.view_id());
    } else if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {
      ++counts.unavailable;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // as the CLI's retry would
    } else {
      ++counts.other;
      std::cerr << "enroll: " << status.error_message() << "\n";
    }
  }
}

// PostgreSQL restarted under the robots and an enrolling client (`restart` runs it): every robot
// should stream on without a break, once it is back every session's checkpoints resume,
// enrollments meanwhile are answered UNAVAILABLE (never anything else), and every enrollment
// answered STORED is in the database.
nlohmann::json RestartTrial(int trial, const std::string& postgres, int servers, int robots,
                            double lease, const std::string& restart) {
  FleetRun run(postgres, servers, robots, lease);
  const std::string& db = run.db;
  std::vector<RobotResult>& results = run.results;
  {
    v1::CreateDatabaseRequest create;
    create.set_name("restart");
    v1::CrossingDatabase created;
    grpc::ClientContext context;
    v1::CrossingService::NewStub(client::MakeChannel(run.servers[0]->address()))
        ->CreateDatabase(&context, create, &created);
  }
  std::string fleet_addresses;
  for (const auto& server : run.servers) {
    fleet_addresses += (fleet_addresses.empty() ? "" : ",") + server->address();
  }
  std::atomic<bool> stop_enrolling{false};
  EnrollCounts enrolled;
  std::thread enroller(Enroller, fleet_addresses, std::cref(stop_enrolling), std::ref(enrolled));
  std::this_thread::sleep_for(std::chrono::seconds(3));
  const auto down = Clock::now();
  const int rc = std::system(restart.c_str());
  const double restart_s = Seconds(down, Clock::now());
  std::this_thread::sleep_for(std::chrono::seconds(4));
  run.StopRobots();
  stop_enrolling = true;
  enroller.join();
  // Every view answered STORED is in the database (nothing committed lost).
  std::string ids;
  for (int64_t id : enrolled.stored) ids += (ids.empty() ? "" : ",") + std::to_string(id);
  auto present = storage::pg::QueryText(
      db, "SELECT COUNT(*)::text FROM view WHERE id = ANY('{" + ids + "}'::bigint[])");
  const int stored_present = present.ok() ? std::stoi(*present) : -1;
  // The last scans after each session's last checkpoint are in memory only (fewer than 5).
  const std::map<std::string, int64_t> stored = StoredScans(db);
  int broken = 0;
  int64_t worst_gap = 0;
  for (const RobotResult& r : results) {
    broken += r.breaks > 0 ? 1 : 0;
    auto it = stored.find(r.session);
    const int64_t have = it == stored.end() ? 0 : it->second;
    worst_gap = std::max(worst_gap, static_cast<int64_t>(r.answered) - have);
  }
  std::cerr << fmt::format(
      "restart trial {}: restart took {:.2f} s (rc {}), {} robots' streams broke, largest "
      "answered-but-unsaved gap {} scans; enrollments {} stored ({} of them in the database), "
      "{} UNAVAILABLE, {} other\n",
      trial, restart_s, rc, broken, worst_gap, enrolled.ok, stored_present, enrolled.unavailable,
      enrolled.other);
  return {{"restart_s", restart_s},
          {"robots_broken", broken},
          {"largest_unsaved_gap", worst_gap},
          {"enrolled_stored", enrolled.ok},
          {"stored_in_database", stored_present},
          {"enroll_unavailable", enrolled.unavailable},
          {"enroll_other_errors", enrolled.other}};
}

nlohmann::json Trial(int trial, const std::string& postgres, int servers, int robots,
                     double lease) {
  FleetRun run(postgres, servers, robots, lease);
  const std::string& db = run.db;
  std::vector<std::unique_ptr<testing::ServerProcess>>& fleet = run.servers;
  std::vector<RobotResult>& results = run.results;
  std::this_thread::sleep_for(std::chrono::seconds(3));
  // The server holding the most sessions, from the leases in the database.
  auto victim_address =
      storage::pg::QueryText(db,
                             "SELECT lease_address FROM slam_session GROUP BY lease_address "
                             "ORDER BY COUNT(*) DESC LIMIT 1");
  int victim = 0;
  for (int s = 0; s < servers; ++s) {
    if (victim_address.ok() && fleet[s]->address() == *victim_address) victim = s;
  }
  auto held = storage::pg::QueryText(
      db, fmt::format("SELECT string_agg(id, ',') FROM slam_session WHERE lease_address = '{}'",
                      fleet[victim]->address()));
  run.killed_at_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
  fleet[victim]->Stop(SIGKILL);
  std::this_thread::sleep_for(std::chrono::duration<double>(lease + 4.0));
  run.StopRobots();

  const std::string held_ids = held.ok() ? *held : "";
  std::vector<double> back;
  int moved = 0, others_broken = 0, never_back = 0;
  int64_t lost = 0;
  for (const RobotResult& r : results) {
    const bool was_held = !r.session.empty() && held_ids.find(r.session) != std::string::npos;
    if (was_held) {
      ++moved;
      lost += r.lost;
      if (r.back_after_s >= 0) {
        back.push_back(r.back_after_s);
      } else {
        ++never_back;
      }
    } else if (r.breaks > 0) {
      ++others_broken;
    }
  }
  std::cerr << fmt::format(
      "trial {}: {} robots moved, back after p50 {:.2f} s (max {:.2f}), "
      "{} scans lost, {} others broken, {} never back\n",
      trial, moved, Quantile(back, 0.5), Quantile(back, 1.0), lost, others_broken, never_back);
  return {{"robots_moved", moved},
          {"back_after_s", back},
          {"scans_lost", lost},
          {"other_robots_broken", others_broken},
          {"never_back", never_back}};
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  std::string postgres, out_dir = "out/bench";
  int robots = 20, servers = 3, trials = 20;
  double lease = 3;
  CLI::App app{"SLAM sessions over a fleet of servers when one is killed"};
  app.add_option("--postgres", postgres, "PostgreSQL server URI")->required();
  app.add_option("--robots", robots, "simulated robots")->capture_default_str();
  app.add_option("--servers", servers, "servers on the database")->capture_default_str();
  app.add_option("--trials", trials, "trials (a server killed in each)")->capture_default_str();
  app.add_option("--lease", lease, "--session-lease-seconds of the servers")->capture_default_str();
  app.add_option("--out", out_dir, "where to write failover_bench.json")->capture_default_str();
  std::string restart;
  app.add_option("--restart-command", restart,
                 "instead of killing a server, run this command (restarting PostgreSQL) under "
                 "the robots");
  CLI11_PARSE(app, argc, argv);
  if (!restart.empty()) {
    nlohmann::json restarts = nlohmann::json::array();
    for (int t = 0; t < trials; ++t) {
      restarts.push_back(
          waymark::bench::RestartTrial(t, postgres, servers, robots, lease, restart));
    }
    std::filesystem::create_directories(out_dir);
    std::ofstream(out_dir + "/postgres_restart_bench.json") << restarts.dump(2) << "\n";
    return 0;
  }
  nlohmann::json runs = nlohmann::json::array();
  std::vector<double> back;
  int64_t lost = 0;
  int others = 0, never = 0;
  for (int t = 0; t < trials; ++t) {
    nlohmann::json run = waymark::bench::Trial(t, postgres, servers, robots, lease);
    for (double s : run["back_after_s"]) back.push_back(s);
    lost += run["scans_lost"].get<int64_t>();
    others += run["other_robots_broken"].get<int>();
    never += run["never_back"].get<int>();
    runs.push_back(run);
  }
  nlohmann::json summary = {{"robots", robots},
                            {"servers", servers},
                            {"trials", trials},
                            {"lease_s", lease},
                            {"robots_moved", back.size() + never},
                            {"back_after_p50_s", waymark::bench::Quantile(back, 0.5)},
                            {"back_after_p99_s", waymark::bench::Quantile(back, 0.99)},
                            {"back_after_max_s", waymark::bench::Quantile(back, 1.0)},
                            {"scans_lost", lost},
                            {"other_robots_broken", others},
                            {"never_back", never},
                            {"runs", runs}};
  std::cerr << summary.dump(2) << "\n";
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir + "/failover_bench.json") << summary.dump(2) << "\n";
  return 0;
}

// waymark-fleet-bench: several waymark-server processes on one PostgreSQL database (issue 19).
//
//   waymark-fleet-bench --postgres postgresql://USER@HOST:PORT/postgres [--views 200]
//
// Measures, on real images from ../shared (corridor references and augmented copies):
//   1. enroll-to-visible: a view enrolled on server A, until server B's GetDatabaseStats counts
//      it (B follows through LISTEN/NOTIFY), p50/p99 over --visible views;
//   2. the enrollment rate of one server alone, then of two servers enrolling into one database
//      at once (half the views each, through BulkEnroll), same views, same run, and whether both
//      servers end with the same clusters.
// Writes fleet_bench.json to --out.

#include <fmt/format.h>
#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "bench/common/bench_images.h"
#include "storage/postgres/pg_admin.h"
#include "tests/support/server_process.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::bench {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::unique_ptr<grpc::ClientContext> Ctx(int seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1) + 0.5)];
}

struct View {
  std::string crossing;
  double heading;
  std::string jpeg;
};

std::vector<View> MakeViews(const std::vector<std::string>& sources, int n) {
  std::vector<View> views;
  std::vector<cv::Mat> originals;
  for (const auto& path : sources) originals.push_back(cv::imread(path, cv::IMREAD_COLOR));
  for (int i = 0; i < n; ++i) {
    const int k = i / static_cast<int>(sources.size());
    std::vector<uchar> jpeg;
    cv::imencode(".jpg", Augment(originals[i % sources.size()], k % kAugmentations), jpeg);
    views.push_back(
        {fmt::format("c{:04d}", i / 12), 30.0 * (i % 12), std::string(jpeg.begin(), jpeg.end())});
  }
  return views;
}

class Server {
 public:
  explicit Server(const std::string& db) {
    auto started = testing::ServerProcess::Start(testing::ServerBinary(), db);
    if (!started.ok()) throw std::runtime_error(started.status().ToString());
    process_ = *std::move(started);
    grpc::ChannelArguments args;
    args.SetMaxSendMessageSize(64 << 20);
    stub_ = v1::CrossingService::NewStub(
        grpc::CreateCustomChannel(process_->address(), grpc::InsecureChannelCredentials(), args));
  }
  v1::CrossingService::Stub& stub() { return *stub_; }

  int Views(const std::string& database) {
    v1::GetDatabaseStatsRequest request;
    request.set_name(database);
    v1::DatabaseStats stats;
    return stub_->GetDatabaseStats(Ctx(10).get(), request, &stats).ok() ? stats.database().views()
                                                                        : -1;
  }

  std::vector<std::pair<int64_t, int>> Clusters(const std::string& database) {
    v1::GetDatabaseStatsRequest request;
    request.set_name(database);
    v1::DatabaseStats stats;
    std::vector<std::pair<int64_t, int>> clusters;
    if (!stub_->GetDatabaseStats(Ctx(10).get(), request, &stats).ok()) return clusters;
    for (const auto& c : stats.clusters()) clusters.emplace_back(c.center_view_id(), c.members());
    return clusters;
  }

 private:
  std::unique_ptr<testing::ServerProcess> process_;
  std::unique_ptr<v1::CrossingService::Stub> stub_;
};

void CreateDatabase(Server& server, const std::string& name) {
  v1::CreateDatabaseRequest create;
  create.set_name(name);
  v1::CrossingDatabase created;
  const grpc::Status status = server.stub().CreateDatabase(Ctx(10).get(), create, &created);
  if (!status.ok()) throw std::runtime_error("CreateDatabase: " + status.error_message());
}

// Streams `views` into `database` through BulkEnroll; the number stored.
int BulkEnroll(Server& server, const std::string& database, const std::vector<const View*>& views) {
  auto ctx = Ctx(3600);
  v1::BulkEnrollResponse summary;
  auto writer = server.stub().BulkEnroll(ctx.get(), &summary);
  for (const View* v : views) {
    v1::EnrollViewRequest request;
    request.set_database(database);
    request.set_crossing(v->crossing);
    request.set_heading_deg(v->heading);
    request.set_create_crossing(true);
    request.mutable_image()->set_data(v->jpeg);
    if (!writer->Write(request)) break;
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) std::cerr << "  bulk enroll stopped: " << status.error_message() << "\n";
  return summary.views();
}

json Visibility(Server& a, Server& b, const std::vector<View>& views, int count) {
  CreateDatabase(a, "visible");
  std::vector<double> delays;
  for (int i = 0; i < count && i < static_cast<int>(views.size()); ++i) {
    v1::EnrollViewRequest request;
    request.set_database("visible");
    request.set_crossing(views[i].crossing);
    request.set_heading_deg(views[i].heading);
    request.set_create_crossing(true);
    request.mutable_image()->set_data(views[i].jpeg);
    v1::EnrollViewResponse response;
    if (!a.stub().EnrollView(Ctx(60).get(), request, &response).ok()) continue;
    const auto enrolled = Clock::now();
    while (b.Views("visible") < i + 1 && Ms(enrolled, Clock::now()) < 30000) {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    delays.push_back(Ms(enrolled, Clock::now()));
  }
  return {{"views", delays.size()},
          {"p50_ms", Quantile(delays, 0.5)},
          {"p99_ms", Quantile(delays, 0.99)},
          {"max_ms", Quantile(delays, 1.0)}};
}

json EnrollmentRates(Server& a, Server& b, const std::vector<View>& views) {
  std::vector<const View*> all, even, odd;
  for (size_t i = 0; i < views.size(); ++i) {
    all.push_back(&views[i]);
    (i % 2 == 0 ? even : odd).push_back(&views[i]);
  }
  json out;
  CreateDatabase(a, "alone");
  auto start = Clock::now();
  const int alone = BulkEnroll(a, "alone", all);
  out["one_server"] = {{"views", alone}, {"views_per_s", alone / (Ms(start, Clock::now()) / 1000)}};

  CreateDatabase(a, "shared");
  while (b.Views("shared") < 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  int on_a = 0, on_b = 0;
  start = Clock::now();
  std::thread enroll_a([&] { on_a = BulkEnroll(a, "shared", even); });
  std::thread enroll_b([&] { on_b = BulkEnroll(b, "shared", odd); });
  enroll_a.join();
  enroll_b.join();
  const double seconds = Ms(start, Clock::now()) / 1000;
  // Both servers settle on what is stored (a notification each way at most).
  const int total = on_a + on_b;
  const auto settle = Clock::now();
  while ((a.Views("shared") != total || b.Views("shared") != total) &&
         Ms(settle, Clock::now()) < 30000) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  out["two_servers"] = {{"views", total},
                        {"views_per_s", total / seconds},
                        {"same_clusters_on_both", a.Clusters("shared") == b.Clusters("shared")},
                        {"clusters", a.Clusters("shared").size()},
                        {"clusters_one_server", a.Clusters("alone").size()}};
  return out;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  std::string shared = "../shared", out_dir = "out/bench", postgres;
  int views = 200, visible = 50;
  CLI::App app{
      "Several servers on one PostgreSQL database: enroll-to-visible delay, enrollment rate"};
  app.add_option("--postgres", postgres,
                 "PostgreSQL server URI (a database waymark_fleet_bench "
                 "is created there, dropped first)")
      ->required();
  app.add_option("--shared", shared, "the shared data folder")->capture_default_str();
  app.add_option("--out", out_dir, "where to write fleet_bench.json")->capture_default_str();
  app.add_option("--views", views, "views per enrollment-rate run")->capture_default_str();
  app.add_option("--visible", visible, "views timed from enrolled to visible")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  using namespace waymark::bench;
  const auto sources = DatabaseSourceImages(shared);
  if (sources.empty()) {
    std::cerr << "no images under " << shared << "/data\n";
    return 2;
  }
  std::cerr << "preparing " << views << " views\n";
  const std::vector<View> all = MakeViews(sources, views);
  auto db = waymark::storage::pg::RecreateDatabase(postgres, "waymark_fleet_bench");
  if (!db.ok()) {
    std::cerr << db.status() << "\n";
    return 2;
  }
  Server a(*db);
  Server b(*db);
  nlohmann::json results;
  std::cerr << "enroll-to-visible\n";
  results["enroll_to_visible"] = Visibility(a, b, all, visible);
  std::cerr << results.dump(2) << "\nenrollment rates\n";
  results["enrollment"] = EnrollmentRates(a, b, all);
  std::cerr << results.dump(2) << "\n";
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir + "/fleet_bench.json") << results.dump(2) << "\n";
  return 0;
}

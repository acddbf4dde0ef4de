// waymark-bench-recognition: RecognizeCrossing latency over gRPC on loopback as the database grows
// (36, 360, 3,600 views of real images), against the query's own SIFT extraction time and a
// brute-force baseline (OpenCV BFMatcher against every view) measured in the same run; server
// memory against the descriptor bytes held; cluster rebuild time; and how often the index's
// decisions differ from exact matching.
//
//   waymark-bench-recognition --shared ../shared --out out/bench [--sizes 1200,3600,12000]
//
// The databases are what `waymark db create` makes by default (retrieval mode, RootSIFT,
// kept aspect, the global stage); --paper-features measures the paper's features instead.

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <thread>
#include <cmath>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/common/bench_images.h"
#include "server/crossing/decision.h"
#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/hue_histogram.h"
#include "server/crossing/recognizer.h"
#include "server/crossing/view_matching.h"
#include "storage/postgres/pg_admin.h"
#include "tests/support/server_process.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::bench {
namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = p * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double frac = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - frac) + v[i + 1] * frac : v[i];
}

long RssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

std::string Jpeg(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
  return std::string(bytes.begin(), bytes.end());
}

struct BenchView {
  std::string crossing;
  double heading;
  std::string jpeg;
  crossing::ImageFeatures features;
};

// View i of the benchmark database: augmentation-major order, so small databases hold originals.
// `extract`: also the features in-process (the baselines of step 6; not needed with --server-only).
std::vector<BenchView> MakeViews(const std::vector<std::string>& sources, int n, bool extract) {
  std::vector<BenchView> views;
  std::vector<cv::Mat> originals;
  for (const auto& path : sources) originals.push_back(cv::imread(path, cv::IMREAD_COLOR));
  for (int i = 0; i < n; ++i) {
    const int k = i / static_cast<int>(sources.size());
    cv::Mat image = Augment(originals[i % sources.size()], k % kAugmentations);
    // Past sources x kAugmentations views (3,984 with ../shared's 332 images) the augmentations
    // repeat, and a repeated image is a duplicate the server refuses: each further round turns
    // and scales its copies a little more (3 degrees, 4 % per round), so 12,000 views are 12,000
    // distinct images with descriptors of their own.
    if (const int round = k / kAugmentations; round > 0) {
      const cv::Mat turn = cv::getRotationMatrix2D(
          cv::Point2f(image.cols / 2.f, image.rows / 2.f), 3.0 * round, 1.0 + 0.04 * round);
      cv::Mat turned;
      cv::warpAffine(image, turned, turn, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
      image = turned;
    }
    BenchView v;
    v.crossing = fmt::format("c{:04d}", i / 12);
    v.heading = 30.0 * (i % 12);
    v.jpeg = Jpeg(image);
    if (extract) {
      auto f = crossing::ExtractFeatures(v.jpeg, crossing::FeatureOptions{});
      if (f.ok()) v.features = std::move(*f);
    }
    views.push_back(std::move(v));
    if ((i + 1) % 200 == 0) std::cerr << "  prepared " << (i + 1) << "/" << n << " views\r";
  }
  std::cerr << "\n";
  return views;
}

std::unique_ptr<grpc::ClientContext> Ctx(int seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

// The linear-scan baseline: OpenCV's BFMatcher (L2, k = 2) against every view, ratio test.
std::vector<int> BruteForceCounts(const cv::Mat& query, const std::vector<cv::Mat>& views,
                                  double ratio) {
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<int> counts;
  cv::Mat qf;
  query.convertTo(qf, CV_32F);
  for (const cv::Mat& v : views) {
    std::vector<std::vector<cv::DMatch>> knn;
    if (v.rows >= 2 && qf.rows > 0) matcher.knnMatch(qf, v, knn, 2);
    int m = 0;
    for (const auto& pair : knn) {
      if (pair.size() == 2 && pair[0].distance < ratio * pair[1].distance) ++m;
    }
    counts.push_back(m);
  }
  return counts;
}

// RSS of a server holding no views: the libraries' own footprint, subtracted before comparing
// with the descriptor bytes.
double EmptyServerRssMb(const std::string& work_dir) {
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), work_dir + "/empty.db");
  if (!server.ok()) throw std::runtime_error(server.status().ToString());
  const double mb = RssKb((*server)->pid()) / 1024.0;
  (*server)->Stop(SIGTERM);
  return mb;
}

struct RunFlags {
  int bf_queries = 5;
  int exact_queries = 20;
  bool server_only = false;  // skip the in-process baselines
  bool skip_rebuild = false;
  // The database keeps the retrieval mode's global stage (DatabaseParams.global_descriptor): its
  // cost at enrollment, the vocabulary's background work and the global scan are measured too.
  bool global_descriptor = true;
  // The paper's features (plain SIFT, squeezed to 4:3) instead of the default database's RootSIFT
  // and kept aspect.
  bool paper_features = false;
  // A PostgreSQL server (libpq URI): each size's database is a fresh PostgreSQL database on it
  // instead of a SQLite file (issue 19: the same measurements on both backends).
  std::string postgres;
};

// The --db of size `n`: a fresh SQLite file, or a fresh PostgreSQL database on flags.postgres.
std::string FreshDatabase(int n, const std::string& work_dir, const RunFlags& flags) {
  if (flags.postgres.empty()) {
    const std::string path = fmt::format("{}/bench-{}.db", work_dir, n);
    std::filesystem::remove(path);
    return path;
  }
  auto uri = storage::pg::RecreateDatabase(flags.postgres, fmt::format("waymark_bench_{}", n));
  if (!uri.ok()) throw std::runtime_error(uri.status().ToString());
  return *uri;
}

// Polls the stats until the global stage has settled (every view coded under a vocabulary due for
// the database's size); returns the seconds waited, or -1 after `timeout_s`.
double WaitForGlobalStage(v1::CrossingService::Stub& stub, int views, double timeout_s) {
  const auto start = Clock::now();
  const int due = views < 16 ? 0 : std::min(512, 16 << static_cast<int>(std::log2(views / 16)));
  while (Ms(start, Clock::now()) < timeout_s * 1000) {
    v1::GetDatabaseStatsRequest request;
    request.set_name("bench");
    v1::DatabaseStats stats;
    grpc::ClientContext ctx;
    if (stub.GetDatabaseStats(&ctx, request, &stats).ok() && stats.vocabulary_views() >= due &&
        (due == 0 || stats.coded_views() == stats.database().views())) {
      return Ms(start, Clock::now()) / 1000;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return -1;
}

json RunSize(int n, const std::vector<BenchView>& all_views, const std::vector<std::string>& queries,
             const std::vector<cv::Mat>& sources, const std::string& work_dir,
             const RunFlags& flags, double empty_rss_mb) {
  const int bf_queries = flags.bf_queries, exact_queries = flags.exact_queries;
  json out;
  out["views"] = n;
  const std::vector<BenchView> views(all_views.begin(), all_views.begin() + n);
  const std::string db_path = FreshDatabase(n, work_dir, flags);
  out["backend"] = flags.postgres.empty() ? "sqlite" : "postgresql";

  // 1. Enroll through the real server.
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), db_path);
  if (!server.ok()) throw std::runtime_error(server.status().ToString());
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(64 << 20);
  auto channel = grpc::CreateCustomChannel((*server)->address(), grpc::InsecureChannelCredentials(), args);
  auto stub = v1::CrossingService::NewStub(channel);
  v1::CreateDatabaseRequest create;
  create.set_name("bench");
  // What `waymark db create` sends by default (client/cli/db_commands.cc): the best measured
  // configuration.
  create.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  create.mutable_params()->set_root_sift(!flags.paper_features);
  create.mutable_params()->set_keep_aspect(!flags.paper_features);
  create.mutable_params()->set_global_descriptor(flags.global_descriptor);
  out["global_descriptor"] = flags.global_descriptor;
  out["root_sift"] = !flags.paper_features;
  v1::CrossingDatabase created;
  stub->CreateDatabase(Ctx(10).get(), create, &created);
  const auto enroll_start = Clock::now();
  {
    auto ctx = Ctx(3600);
    v1::BulkEnrollResponse summary;
    auto writer = stub->BulkEnroll(ctx.get(), &summary);
    for (const BenchView& v : views) {
      v1::EnrollViewRequest r;
      r.set_database("bench");
      r.set_crossing(v.crossing);
      r.set_heading_deg(v.heading);
      r.set_create_crossing(true);
      r.mutable_image()->set_data(v.jpeg);
      writer->Write(r);
    }
    writer->WritesDone();
    const grpc::Status s = writer->Finish();
    if (!s.ok()) std::cerr << "  bulk enroll stopped: " << s.error_message() << "\n";
    out["enrolled"] = summary.views();
  }
  out["enroll_s"] = Ms(enroll_start, Clock::now()) / 1000;
  // The vocabulary's background work left after the last view was committed.
  if (flags.global_descriptor) out["global_settle_s"] = WaitForGlobalStage(*stub, n, 1800);

  // 2. Restart: memory after a clean load, as a server runs in production.
  (*server)->Stop(SIGTERM);
  const auto load_start = Clock::now();
  server = testing::ServerProcess::Start(testing::ServerBinary(), db_path);
  out["restart_s"] = Ms(load_start, Clock::now()) / 1000;
  if (!server.ok()) throw std::runtime_error(server.status().ToString());
  channel = grpc::CreateCustomChannel((*server)->address(), grpc::InsecureChannelCredentials(), args);
  stub = v1::CrossingService::NewStub(channel);
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("bench");
  v1::DatabaseStats stats;
  stub->GetDatabaseStats(Ctx(10).get(), stats_request, &stats);
  out["clusters"] = stats.database().clusters();
  out["keypoints"] = stats.keypoints();
  out["descriptor_mb"] = stats.descriptor_bytes() / 1048576.0;
  out["vocabulary_views"] = stats.vocabulary_views();
  out["coded_views"] = stats.coded_views();

  // 3. Latency of RecognizeCrossing on loopback, in each mode.
  std::vector<std::string> query_jpegs;
  for (const auto& q : queries) query_jpegs.push_back(Jpeg(Augment(cv::imread(q), 0)));
  // Half the queries revisit stored views (every database size holds the first sources).
  for (const cv::Mat& source : sources) query_jpegs.push_back(Jpeg(Revisit(source)));
  for (const auto& [mode_name, mode] :
       std::vector<std::pair<std::string, v1::RecognitionMode>>{
           {"paper", v1::RECOGNITION_MODE_PAPER},
           {"verified", v1::RECOGNITION_MODE_VERIFIED},
           {"retrieval", v1::RECOGNITION_MODE_RETRIEVAL}}) {
    std::vector<double> latency, extraction, matching, histogram, verification, retrieval;
    int recognized = 0;
    for (int pass = 0; pass < 2; ++pass) {  // pass 0 warms up
      for (const std::string& jpeg : query_jpegs) {
        v1::RecognizeRequest q;
        q.set_database("bench");
        q.mutable_image()->set_data(jpeg);
        q.mutable_params()->set_mode(mode);
        v1::RecognizeResponse r;
        const auto t0 = Clock::now();
        const grpc::Status s = stub->RecognizeCrossing(Ctx(60).get(), q, &r);
        const auto t1 = Clock::now();
        if (pass == 0 || !s.ok()) continue;
        latency.push_back(Ms(t0, t1));
        extraction.push_back(r.timings().extraction_ms());
        matching.push_back(r.timings().matching_ms());
        histogram.push_back(r.timings().histogram_ms());
        verification.push_back(r.timings().verification_ms());
        retrieval.push_back(r.timings().retrieval_ms());
        recognized += r.recognized();
      }
    }
    out[mode_name] = {{"latency_ms_p50", Percentile(latency, 0.5)},
                      {"latency_ms_p99", Percentile(latency, 0.99)},
                      {"extraction_ms_p50", Percentile(extraction, 0.5)},
                      {"matching_ms_p50", Percentile(matching, 0.5)},
                      {"histogram_ms_p50", Percentile(histogram, 0.5)},
                      {"verification_ms_p50", Percentile(verification, 0.5)},
                      {"retrieval_ms_p50", Percentile(retrieval, 0.5)},
                      {"recognized", recognized},
                      {"queries", latency.size()}};
  }

  // The target compares with the query's own SIFT extraction, timed inside the server for the
  // same requests (an in-process timing at another moment would add the machine's noise).
  out["paper_latency_over_sift"] = out["paper"]["latency_ms_p50"].get<double>() /
                                   out["paper"]["extraction_ms_p50"].get<double>();
  out["retrieval_latency_over_sift"] = out["retrieval"]["latency_ms_p50"].get<double>() /
                                       out["retrieval"]["extraction_ms_p50"].get<double>();

  // 4. Server memory vs descriptor bytes.
  const long rss_kb = RssKb((*server)->pid());
  out["server_rss_mb"] = rss_kb / 1024.0;
  out["empty_server_rss_mb"] = empty_rss_mb;
  out["rss_growth_over_descriptors"] =
      (rss_kb / 1024.0 - empty_rss_mb) / std::max(1e-9, out["descriptor_mb"].get<double>());

  // 5. Cluster rebuild (the server's index-based clustering).
  if (flags.skip_rebuild || flags.server_only) {
    (*server)->Stop(SIGTERM);
    if (flags.server_only) return out;
  }
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database("bench");
  v1::RebuildClustersResponse rebuilt;
  if (!flags.skip_rebuild) {
    stub->RebuildClusters(Ctx(3600).get(), rebuild, &rebuilt);
    out["rebuild_clusters_s"] = rebuilt.elapsed_ms() / 1000;
    out["rebuild_clusters"] = rebuilt.clusters();
    (*server)->Stop(SIGTERM);
  }

  // 6. In the same run: the query's own SIFT extraction, the brute-force baseline, and the index's
  // agreement with exact matching (engine in-process, same features).
  std::vector<double> own_extraction;
  std::vector<crossing::ImageFeatures> query_features;
  for (const std::string& jpeg : query_jpegs) {
    auto image = crossing::DecodeImage(jpeg);
    const cv::Mat working = crossing::ToWorkingResolution(*image, crossing::FeatureOptions{});
    const auto t0 = Clock::now();
    auto f = crossing::ExtractSift(working, crossing::FeatureOptions{});
    own_extraction.push_back(Ms(t0, Clock::now()));
    f->hue_hist = crossing::HueHistogram(working, 36);
    query_features.push_back(std::move(*f));
  }
  const double extraction_p50 = Percentile(own_extraction, 0.5);
  out["query_sift_ms_p50"] = extraction_p50;

  std::vector<cv::Mat> float_views;
  for (const BenchView& v : views) {
    cv::Mat f;
    v.features.descriptors.convertTo(f, CV_32F);
    float_views.push_back(f);
  }
  std::vector<double> bf_ms;
  for (int i = 0; i < std::min<int>(bf_queries, query_features.size()); ++i) {
    const auto t0 = Clock::now();
    BruteForceCounts(query_features[i].descriptors, float_views, 0.32);
    bf_ms.push_back(Ms(t0, Clock::now()));
  }
  out["bruteforce_matching_ms_p50"] = Percentile(bf_ms, 0.5);
  out["bruteforce_latency_est_ms"] = Percentile(bf_ms, 0.5) + extraction_p50;
  out["bruteforce_over_index_matching"] =
      Percentile(bf_ms, 0.5) / std::max(1e-3, out["paper"]["matching_ms_p50"].get<double>());

  crossing::ViewDatabase indexed, exact_db(crossing::IndexOptions{4, 8, 64, 16, true});
  for (size_t i = 0; i < views.size(); ++i) {
    crossing::EnrollView(&indexed, i + 1, i / 12 + 1, views[i].heading, views[i].features);
  }
  // Same clusters for the exact reference, so only the matching differs.
  for (size_t i = 0; i < views.size(); ++i) {
    exact_db.AddView(i + 1, i / 12 + 1, views[i].heading, views[i].features.descriptors,
                     crossing::KeypointPositions(views[i].features), views[i].features.hue_hist);
  }
  exact_db.SetClusters(indexed.clusters());
  int same_decision = 0, compared = 0;
  double count_abs_diff = 0, count_total = 0;
  for (int i = 0; i < std::min<int>(exact_queries, query_features.size()); ++i) {
    auto a = crossing::Recognize(indexed, query_features[i], {});
    auto b = crossing::Recognize(exact_db, query_features[i], {});
    ++compared;
    const bool same = a->recognized == b->recognized &&
                      (!a->recognized || indexed.views()[a->best_slot].view_id ==
                                             exact_db.views()[b->best_slot].view_id);
    same_decision += same;
    // Match counts of the exact candidate list, as the index sees them.
    const auto via_index = crossing::MatchAllViews(query_features[i].descriptors, indexed.index(),
                                                   indexed.spans(), 0.32, true);
    for (const auto& c : b->candidates) {
      auto it = via_index.find(c.slot);
      const int m = it == via_index.end() ? 0 : static_cast<int>(it->second.size());
      count_abs_diff += std::abs(m - c.matches);
      count_total += c.matches;
    }
  }
  out["index_vs_exact_same_decision"] = compared ? double(same_decision) / compared : 0.0;
  out["index_vs_exact_queries"] = compared;
  out["index_vs_exact_count_error"] = count_total > 0 ? count_abs_diff / count_total : 0.0;
  out["engine_memory_mb"] = indexed.memory_bytes() / 1048576.0;

  // 7. The paper's clustering, quadratic: every view against every centre, exact (36 and 360 only).
  if (n <= 400) {
    const auto t0 = Clock::now();
    const auto centres = crossing::QuadraticClusters(indexed, crossing::ClusterOptions{});
    out["quadratic_clustering_s"] = Ms(t0, Clock::now()) / 1000;
    out["quadratic_clusters"] = centres.size();
  }
  return out;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  std::string shared = "../shared", out_dir = "out/bench";
  std::vector<int> sizes = {1200, 3600, 12000};
  int query_count = 40;
  waymark::bench::RunFlags flags;
  CLI::App app{"RecognizeCrossing latency, memory and clustering as the database grows"};
  app.add_option("--shared", shared, "the shared data folder")->capture_default_str();
  app.add_option("--out", out_dir, "where to write bench_recognition.json/.md")->capture_default_str();
  app.add_option("--sizes", sizes, "database sizes in views")->delimiter(',')->capture_default_str();
  app.add_option("--queries", query_count,
                 "queries per size: half held-out corridor frames, half revisits of stored views")
      ->capture_default_str();
  app.add_option("--bf-queries", flags.bf_queries, "queries for the brute-force baseline")
      ->capture_default_str();
  app.add_option("--exact-queries", flags.exact_queries, "queries for index-vs-exact agreement")
      ->capture_default_str();
  app.add_flag("--server-only", flags.server_only,
               "only the server measurements (latency, memory), no in-process baselines");
  app.add_flag("--skip-rebuild", flags.skip_rebuild, "do not time RebuildClusters");
  app.add_flag("--paper-features", flags.paper_features,
               "the paper's features (SIFT, squeezed to 4:3) instead of RootSIFT + kept aspect");
  app.add_flag("--global-descriptor,!--no-global-descriptor", flags.global_descriptor,
               "keep the retrieval mode's global stage in the databases [on]");
  app.add_option("--postgres", flags.postgres,
                 "a PostgreSQL server URI (postgresql://USER@HOST:PORT/DB): the databases are "
                 "created there (waymark_bench_N, dropped first) instead of as SQLite files");
  CLI11_PARSE(app, argc, argv);

  using namespace waymark::bench;
  const auto sources = DatabaseSourceImages(shared);
  auto queries = QueryImages(shared);
  if (sources.empty() || queries.empty()) {
    std::cerr << "no images under " << shared << "/data: this benchmark needs the shared data\n";
    return 2;
  }
  if (static_cast<int>(queries.size()) > query_count / 2) queries.resize(query_count / 2);
  std::vector<cv::Mat> source_images;  // revisited by the other half of the queries
  for (size_t i = 0; i < queries.size() && i < sources.size(); ++i) {
    source_images.push_back(cv::imread(sources[i], cv::IMREAD_COLOR));
  }
  std::filesystem::create_directories(out_dir);
  const std::string work = waymark::testing::MakeTempDir("waymark-bench");
  const int max_size = *std::max_element(sizes.begin(), sizes.end());
  std::cerr << "preparing " << max_size << " views from " << sources.size() << " real images\n";
  const auto views = MakeViews(sources, max_size, !flags.server_only);

  const double empty_rss_mb = EmptyServerRssMb(work);
  nlohmann::json results = nlohmann::json::array();
  for (int n : sizes) {
    std::cerr << "database of " << n << " views\n";
    results.push_back(
        RunSize(n, views, queries, source_images, work, flags, empty_rss_mb));
    std::cerr << results.back().dump(2) << "\n";
  }
  std::filesystem::remove_all(work);
  std::ofstream(out_dir + "/bench_recognition.json") << results.dump(2) << "\n";

  std::ostringstream md;
  md << "| views | clusters | p50 ms (paper) | p99 ms | extraction | matching | histogram | "
        "p50 / own SIFT | p50 ms (verified) | p50 ms (retrieval) | retrieval p50 / own SIFT | "
        "brute-force matching ms | BF / index matching | "
        "same decision as exact | server RSS MB | descriptor MB | (RSS - empty) / descriptors | "
        "rebuild clusters s |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  const double kNaN = std::numeric_limits<double>::quiet_NaN();  // not measured in this run
  for (const auto& r : results) {
    md << fmt::format(
        "| {} | {} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.2f}x | {:.1f} | {:.1f} | {:.2f}x | "
        "{:.0f} | {:.0f}x | "
        "{:.0f} % | {:.0f} | {:.0f} | {:.2f}x | {:.1f} |\n",
        r.value("views", -1), r.value("clusters", -1), r["paper"].value("latency_ms_p50", kNaN),
        r["paper"].value("latency_ms_p99", kNaN), r["paper"].value("extraction_ms_p50", kNaN),
        r["paper"].value("matching_ms_p50", kNaN), r["paper"].value("histogram_ms_p50", kNaN),
        r.value("paper_latency_over_sift", kNaN), r["verified"].value("latency_ms_p50", kNaN),
        r["retrieval"].value("latency_ms_p50", kNaN), r.value("retrieval_latency_over_sift", kNaN),
        r.value("bruteforce_matching_ms_p50", kNaN), r.value("bruteforce_over_index_matching", kNaN),
        100 * r.value("index_vs_exact_same_decision", kNaN), r.value("server_rss_mb", kNaN),
        r.value("descriptor_mb", kNaN), r.value("rss_growth_over_descriptors", kNaN),
        r.value("rebuild_clusters_s", kNaN));
  }
  md << "\nThe retrieval mode's global stage (databases with global_descriptor):\n\n"
     << "| views | enroll views/s | vocabulary settled after enroll s | restart s | vocabulary "
        "from views | coded views | retrieval stage ms p50 | retrieval p50 ms | retrieval p50 / "
        "own SIFT |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : results) {
    if (!r.value("global_descriptor", false)) continue;
    md << fmt::format("| {} | {:.1f} | {:.1f} | {:.1f} | {} | {} | {:.1f} | {:.1f} | {:.2f}x |\n",
                      r.value("views", -1),
                      r.value("enrolled", 0) / std::max(1e-9, r.value("enroll_s", kNaN)),
                      r.value("global_settle_s", kNaN), r.value("restart_s", kNaN),
                      r.value("vocabulary_views", -1), r.value("coded_views", -1),
                      r["retrieval"].value("retrieval_ms_p50", kNaN),
                      r["retrieval"].value("latency_ms_p50", kNaN),
                      r.value("retrieval_latency_over_sift", kNaN));
  }
  // Issue 34's targets at each size, one row each.
  md << "\nTargets (retrieval p50 <= 2.5x the query's own SIFT, (RSS - empty) <= 1.5x the "
        "descriptor bytes, enrollment >= 30 views/s with the global stage):\n\n"
     << "| views | retrieval p50 ms | own SIFT p50 ms | ratio | of it: global stage ms | "
        "RSS - empty MB | descriptor MB | ratio | enroll views/s |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : results) {
    md << fmt::format("| {} | {:.1f} | {:.1f} | {:.2f}x | {:.1f} | {:.0f} | {:.0f} | {:.2f}x | "
                      "{:.1f} |\n",
                      r.value("views", -1), r["retrieval"].value("latency_ms_p50", kNaN),
                      r["retrieval"].value("extraction_ms_p50", kNaN),
                      r.value("retrieval_latency_over_sift", kNaN),
                      r["retrieval"].value("retrieval_ms_p50", kNaN),
                      r.value("server_rss_mb", kNaN) - r.value("empty_server_rss_mb", kNaN),
                      r.value("descriptor_mb", kNaN), r.value("rss_growth_over_descriptors", kNaN),
                      r.value("enrolled", 0) / std::max(1e-9, r.value("enroll_s", kNaN)));
  }
  std::ofstream(out_dir + "/bench_recognition.md") << md.str();
  std::cout << md.str();
  return 0;
}

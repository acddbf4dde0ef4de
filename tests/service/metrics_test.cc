// The metrics endpoint: address checks, an ephemeral port, the event metrics (fed directly, so
// latency buckets are checked without a clock) and the state metrics read from a real
// SlamRegistry, a real CrossingRegistry and database files, as a scrape over HTTP shows them.

#include "server/service/operations/metrics.h"

#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/slam_store.h"
#include "tests/service/scrape.h"
#include "tests/service/blocking_gate.h"
#include "tests/service/slam_test_world.h"
#include "tests/storage/temp_dir.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::service {
namespace {

using ::waymark::storage::testing::TempDir;
using ::waymark::testing::HttpGet;
using ::waymark::testing::Odom;
using ::waymark::testing::RoomScan;
using ::waymark::testing::Sample;
using ::waymark::testing::TestSessionRequest;

constexpr char kMethod[] = "/waymark.v1.CrossingService/RecognizeCrossing";

std::string Scrape(const Metrics& metrics) {
  absl::StatusOr<std::string> page = HttpGet(metrics.port());
  EXPECT_TRUE(page.ok()) << page.status();
  return page.ok() ? *page : "";
}

void WriteBytes(const std::string& path, size_t n) {
  std::ofstream(path, std::ios::binary) << std::string(n, 'x');
}

TEST(StartMetricsTest, RejectsMalformedAddresses) {
  for (const char* bad : {"", "9100", ":9100", "localhost:9100", "127.0.0.1:", "127.0.0.1:x",
                          "127.0.0.1:65536", "127.0.0.1:-1", "1.2.3:9100", "[::1]:9100"}) {
    absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics(bad, {});
    EXPECT_EQ(metrics.status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
}

TEST(StartMetricsTest, PortZeroPicksAFreePortAndServesTheMetricsPage) {
  absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics("127.0.0.1:0", {});
  ASSERT_TRUE(metrics.ok()) << metrics.status();
  ASSERT_GT((*metrics)->port(), 0);
  (*metrics)->RpcStarted(kMethod);
  const std::string page = Scrape(**metrics);
  EXPECT_EQ(Sample(page, absl::StrCat("waymark_rpc_in_flight{method=\"", kMethod, "\"}")), 1)
      << page;
}

TEST(StartMetricsTest, ServesOnAllInterfaces) {
  absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics("0.0.0.0:0", {});
  ASSERT_TRUE(metrics.ok()) << metrics.status();
  ASSERT_GT((*metrics)->port(), 0);
  EXPECT_TRUE(HttpGet((*metrics)->port()).ok());  // reached on loopback
}

TEST(StartMetricsTest, ABusyPortIsUnavailable) {
  absl::StatusOr<std::unique_ptr<Metrics>> first = StartMetrics("127.0.0.1:0", {});
  ASSERT_TRUE(first.ok()) << first.status();
  absl::StatusOr<std::unique_ptr<Metrics>> second =
      StartMetrics(absl::StrCat("127.0.0.1:", (*first)->port()), {});
  EXPECT_EQ(second.status().code(), absl::StatusCode::kUnavailable) << second.status();
}

TEST(MetricsTest, LatencyLandsInItsBucketAndCodesAreNamed) {
  Metrics metrics({});
  metrics.RpcStarted(kMethod);
  metrics.RpcStarted(kMethod);
  metrics.RpcFinished(kMethod, grpc::StatusCode::OK, 0.003);
  metrics.RpcFinished(kMethod, grpc::StatusCode::RESOURCE_EXHAUSTED, 45);
  const std::string page = metrics.Render();
  auto bucket = [&](const std::string& le) {
    return Sample(page, absl::StrCat("waymark_rpc_latency_seconds_bucket{method=\"", kMethod,
                                     "\",le=\"", le, "\"}"));
  };
  EXPECT_EQ(bucket("0.0025"), 0) << page;
  EXPECT_EQ(bucket("0.005"), 1) << page;
  EXPECT_EQ(bucket("30"), 1) << page;
  EXPECT_EQ(bucket("+Inf"), 2) << page;
  EXPECT_EQ(Sample(page, absl::StrCat("waymark_rpc_latency_seconds_sum{method=\"", kMethod, "\"}")),
            45.003)
      << page;
  EXPECT_EQ(Sample(page, absl::StrCat("waymark_rpc_requests_total{code=\"RESOURCE_EXHAUSTED\","
                                      "method=\"",
                                      kMethod, "\"}")),
            1)
      << page;
  EXPECT_EQ(Sample(page, absl::StrCat("waymark_rpc_in_flight{method=\"", kMethod, "\"}")), 0);
  EXPECT_EQ(StatusCodeName(grpc::StatusCode::UNAUTHENTICATED), "UNAUTHENTICATED");
}

TEST(MetricsTest, RecognitionOutcomes) {
  Metrics metrics({});
  v1::RecognizeResponse recognized;
  recognized.set_recognized(true);
  recognized.set_keypoints(300);
  v1::RecognizeResponse unknown;
  unknown.set_keypoints(300);
  v1::RecognizeResponse featureless;  // keypoints 0
  v1::RecognizeResponse failed_frame;
  failed_frame.set_error_code(3);
  metrics.RecordRecognition(recognized);
  metrics.RecordRecognition(unknown);
  metrics.RecordRecognition(unknown);
  metrics.RecordRecognition(featureless);
  metrics.RecordRecognition(failed_frame);
  metrics.RecordRecognitionError();
  const std::string page = metrics.Render();
  auto outcome = [&](const std::string& o) {
    return Sample(page, absl::StrCat("waymark_recognitions_total{outcome=\"", o, "\"}"));
  };
  EXPECT_EQ(outcome("recognized"), 1) << page;
  EXPECT_EQ(outcome("unknown"), 2) << page;
  EXPECT_EQ(outcome("no_features"), 1) << page;
  EXPECT_EQ(outcome("error"), 2) << page;
}

TEST(MetricsTest, DatabaseBytesAreTheFilePlusItsWriteAheadLog) {
  TempDir dir;
  const std::string db = dir.File("waymark.db");
  WriteBytes(db, 4096);
  WriteBytes(db + "-wal", 1000);
  MetricsSources sources;
  sources.database_path = db;
  Metrics metrics(sources);
  EXPECT_EQ(Sample(metrics.Render(), "waymark_database_bytes"), 5096);
  std::remove((db + "-wal").c_str());
  EXPECT_EQ(Sample(metrics.Render(), "waymark_database_bytes"), 4096);
}

TEST(MetricsTest, NoSourcesNoStateMetrics) {
  const std::string page = Metrics({}).Render();
  EXPECT_EQ(page.find("waymark_slam_"), std::string::npos) << page;
  EXPECT_EQ(page.find("waymark_crossing_views"), std::string::npos) << page;
  EXPECT_EQ(page.find("waymark_database_bytes"), std::string::npos) << page;
}

using Gate = BlockingGate;

TEST(MetricsTest, SlamSessionsAndQueueDepthsAtScrapeTime) {
  TempDir dir;
  Gate gate;
  SlamRegistryOptions options;
  options.workers = 1;
  options.max_batch = 1;
  options.queue_capacity = 10;
  options.before_process = [&gate](const std::string&) { gate.Enter(); };
  auto store = storage::OpenSqliteSlamStore(dir.File("slam.db"));
  ASSERT_TRUE(store.ok()) << store.status();
  auto registry = SlamRegistry::Create(std::move(*store), options);
  ASSERT_TRUE(registry.ok()) << registry.status();

  MetricsSources sources;
  sources.slam = registry->get();
  absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics("127.0.0.1:0", sources);
  ASSERT_TRUE(metrics.ok()) << metrics.status();

  auto busy = (*registry)->CreateSession(TestSessionRequest("r1"));
  auto idle = (*registry)->CreateSession(TestSessionRequest("r2"));
  ASSERT_TRUE(busy.ok() && idle.ok());
  auto closed = (*registry)->CreateSession(TestSessionRequest("r3"));
  ASSERT_TRUE(closed.ok());
  ASSERT_TRUE((*registry)->CloseSession(closed->session_id()).ok());

  auto stream = (*registry)->OpenStream(busy->session_id(), [](const v1::SlamUpdate&) {});
  ASSERT_TRUE(stream.ok()) << stream.status();
  // The worker takes the first message and waits at the gate; the next three queue behind it.
  ASSERT_TRUE((*stream)->Submit(Odom(1, 1.0, 0, 0, 0)).ok());
  gate.WaitEntered(1);
  ASSERT_TRUE((*stream)->Submit(RoomScan(2, 1.0, 0, 0, 0)).ok());
  ASSERT_TRUE((*stream)->Submit(Odom(3, 2.0, 0.1, 0, 0)).ok());
  ASSERT_TRUE((*stream)->Submit(RoomScan(4, 2.0, 0.1, 0, 0)).ok());

  std::string page = Scrape(**metrics);
  EXPECT_EQ(Sample(page, "waymark_slam_sessions_active"), 2) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_queue_depth"), 3) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_queue_depth_max"), 3) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_queue_capacity"), 10) << page;

  gate.Open();
  (*stream)->Close();  // waits until every accepted message is processed
  page = Scrape(**metrics);
  EXPECT_EQ(Sample(page, "waymark_slam_queue_depth"), 0) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_queue_depth_max"), 0) << page;
  stream->reset();
  metrics->reset();  // before the registry it reads
}

// Issue 35: per-session SLAM metrics (scans, loop closures, queue depth, per-scan processing
// time) while the session is in memory, and a server-wide scan count and latency histogram. A
// closed session's labels go away: the label values stay bounded.
TEST(MetricsTest, PerSessionSlamMetricsWhileTheSessionIsInMemory) {
  TempDir dir;
  SlamRegistryOptions options;
  options.workers = 1;
  auto store = storage::OpenSqliteSlamStore(dir.File("slam.db"));
  ASSERT_TRUE(store.ok()) << store.status();
  auto registry = SlamRegistry::Create(std::move(*store), options);
  ASSERT_TRUE(registry.ok()) << registry.status();
  MetricsSources sources;
  sources.slam = registry->get();
  absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics("127.0.0.1:0", sources);
  ASSERT_TRUE(metrics.ok()) << metrics.status();

  auto session = (*registry)->CreateSession(TestSessionRequest("r1"));
  ASSERT_TRUE(session.ok()) << session.status();
  const std::string id = session->session_id();
  auto stream = (*registry)->OpenStream(id, [](const v1::SlamUpdate&) {});
  ASSERT_TRUE(stream.ok()) << stream.status();
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE((*stream)->Submit(Odom(2 * i + 1, 1.0 + i, 0.1 * i, 0, 0)).ok());
    ASSERT_TRUE((*stream)->Submit(RoomScan(2 * i + 2, 1.0 + i, 0.1 * i, 0, 0)).ok());
  }
  (*stream)->Close();  // every scan processed and answered

  const std::string label = "{session=\"" + id + "\"}";
  std::string page = Scrape(**metrics);
  EXPECT_EQ(Sample(page, "waymark_slam_session_scans" + label), 3) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_session_queue_depth" + label), 0) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_session_loop_closures" + label), 0) << page;
  const std::optional<double> p50 = Sample(
      page, "waymark_slam_session_scan_seconds{quantile=\"0.5\",session=\"" + id + "\"}");
  const std::optional<double> p99 = Sample(
      page, "waymark_slam_session_scan_seconds{quantile=\"0.99\",session=\"" + id + "\"}");
  ASSERT_TRUE(p50.has_value() && p99.has_value()) << page;
  EXPECT_GE(*p50, 0);
  EXPECT_GE(*p99, *p50);
  EXPECT_EQ(Sample(page, "waymark_slam_scans_total"), 3) << page;
  EXPECT_EQ(Sample(page, "waymark_slam_scan_seconds_count"), 3) << page;

  stream->reset();
  ASSERT_TRUE((*registry)->CloseSession(id).ok());
  page = Scrape(**metrics);
  EXPECT_EQ(page.find(id), std::string::npos) << page;  // no label of a session gone
  EXPECT_EQ(Sample(page, "waymark_slam_scans_total"), 3) << page;
  metrics->reset();  // before the registry it reads
}

TEST(MetricsTest, ViewsPerCrossingDatabase) {
  TempDir dir;
  const std::string db_path = dir.File("waymark.db");
  auto store = storage::OpenSqliteCrossingStore(db_path);
  ASSERT_TRUE(store.ok()) << store.status();
  auto registry = CrossingRegistry::Load(std::move(*store));
  ASSERT_TRUE(registry.ok()) << registry.status();
  for (const char* name : {"campus", "empty"}) {
    v1::CreateDatabaseRequest create;
    create.set_name(name);
    ASSERT_TRUE((*registry)->CreateDatabase(create).ok());
  }
  const cv::Mat panorama = testing::MakePanorama(7);
  for (double heading : {0.0, 120.0}) {
    v1::EnrollViewRequest view;
    view.set_database("campus");
    view.set_crossing("main-gate");
    view.set_create_crossing(true);
    view.set_heading_deg(heading);
    view.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama, heading)));
    auto enrolled = (*registry)->EnrollView(view);
    ASSERT_TRUE(enrolled.ok()) << enrolled.status();
  }

  MetricsSources sources;
  sources.crossings = registry->get();
  sources.database_path = db_path;
  absl::StatusOr<std::unique_ptr<Metrics>> metrics = StartMetrics("127.0.0.1:0", sources);
  ASSERT_TRUE(metrics.ok()) << metrics.status();
  const std::string page = Scrape(**metrics);
  EXPECT_EQ(Sample(page, "waymark_crossing_views{database=\"campus\"}"), 2) << page;
  EXPECT_EQ(Sample(page, "waymark_crossing_views{database=\"empty\"}"), 0) << page;
  const std::optional<double> bytes = Sample(page, "waymark_database_bytes");
  ASSERT_TRUE(bytes.has_value()) << page;
  EXPECT_GT(*bytes, 0);
}

}  // namespace
}  // namespace waymark::service

// waymark-store-bench: the stores' calls on both backends, side by side (issue 19): what one
// enrollment, a server's load of a view, a SLAM checkpoint and a token check cost in the database
// layer on a SQLite file and on PostgreSQL. Recognition itself never touches the store.
//
//   WAYMARK_BENCH_POSTGRES=postgresql://USER@HOST:PORT/postgres waymark-store-bench
//
// The PostgreSQL half needs a server (any database it names is used only to create
// waymark_store_bench, dropped first); without the variable it reports itself skipped.
// Argument 0 = SQLite, 1 = PostgreSQL.

#include <cstdlib>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "storage/postgres/pg_admin.h"
#include "storage/slam_store.h"
#include "storage/token_store.h"
#include "tests/support/server_process.h"

namespace waymark::bench {
namespace {

using storage::ViewRecord;

// A fresh database on the backend the benchmark's argument names; "" (and the benchmark
// skipped) when PostgreSQL is asked for and no server is given.
std::string FreshDatabase(benchmark::State& state) {
  if (state.range(0) == 0) {
    static const std::string dir = testing::MakeTempDir("waymark-store-bench");
    static int n = 0;
    return dir + "/bench-" + std::to_string(n++) + ".db";
  }
  const char* server = std::getenv("WAYMARK_BENCH_POSTGRES");
  if (server == nullptr || *server == '\0') {
    state.SkipWithError("set WAYMARK_BENCH_POSTGRES to a PostgreSQL server URI");
    return "";
  }
  auto uri = storage::pg::RecreateDatabase(server, "waymark_store_bench");
  if (!uri.ok()) {
    state.SkipWithError(std::string(uri.status().message()).c_str());
    return "";
  }
  return *uri;
}

// A view as a retrieval-mode enrollment stores it: 250 keypoints, their descriptors, the
// histogram, a 40 KB working image and a 32 KB descriptor sample.
ViewRecord RealisticView(int64_t crossing_id, int serial) {
  std::mt19937 random(serial);
  ViewRecord view;
  view.crossing_id = crossing_id;
  view.heading_deg = serial % 360;
  view.width = 320;
  view.height = 240;
  view.keypoint_count = 250;
  view.keypoints.resize(250 * storage::kKeypointFloats);
  for (float& f : view.keypoints) f = static_cast<float>(random() % 320);
  view.descriptors.resize(250 * storage::kDescriptorBytes);
  for (uint8_t& b : view.descriptors) b = static_cast<uint8_t>(random());
  view.hue_hist.assign(36, 1.0f / 36);
  view.content_sha256 = std::string(32, '\0');
  for (char& c : view.content_sha256) c = static_cast<char>(random());
  view.work_image.assign(40000, 'p');
  view.global_sample.assign(32768, 's');
  return view;
}

// A crossing store on a fresh database of the benchmark's backend, holding one crossing database
// with one crossing; nullopt (and the benchmark skipped) when it cannot be had.
struct CrossingFixture {
  std::unique_ptr<storage::CrossingStore> store;
  int64_t database = 0;
  int64_t crossing = 0;
};
std::optional<CrossingFixture> OpenCrossingFixture(benchmark::State& state) {
  const std::string db = FreshDatabase(state);
  if (db.empty()) return std::nullopt;
  auto store = storage::OpenCrossingStore(db);
  if (!store.ok()) {
    state.SkipWithError(std::string(store.status().message()).c_str());
    return std::nullopt;
  }
  CrossingFixture fixture;
  fixture.store = *std::move(store);
  fixture.database = fixture.store->CreateDatabase("bench", "{}")->id;
  fixture.crossing = fixture.store->AddCrossing(fixture.database, "c", "")->id;
  return fixture;
}

void BM_AddView(benchmark::State& state) {
  std::optional<CrossingFixture> fixture = OpenCrossingFixture(state);
  if (!fixture.has_value()) return;
  auto& store = fixture->store;
  const int64_t crossing = fixture->crossing;
  int serial = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const ViewRecord view = RealisticView(crossing, serial++);
    state.ResumeTiming();
    auto added = store->AddView(view, {});
    if (!added.ok()) return state.SkipWithError(std::string(added.status().message()).c_str());
  }
}
BENCHMARK(BM_AddView)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(300);

// Reading every view of a 500-view database, per view: what a server's start-up costs.
void BM_LoadViewsPerView(benchmark::State& state) {
  std::optional<CrossingFixture> fixture = OpenCrossingFixture(state);
  if (!fixture.has_value()) return;
  auto& store = fixture->store;
  const int64_t database = fixture->database;
  const int64_t crossing = fixture->crossing;
  constexpr int kViews = 500;
  for (int i = 0; i < kViews; ++i) store->AddView(RealisticView(crossing, i), {}).IgnoreError();
  for (auto _ : state) {
    int seen = 0;
    store
        ->ForEachView(database, [&seen](ViewRecord&&) {
          ++seen;
          return absl::OkStatus();
        })
        .IgnoreError();
    benchmark::DoNotOptimize(seen);
  }
  state.SetItemsProcessed(state.iterations() * kViews);
}
BENCHMARK(BM_LoadViewsPerView)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// A periodic checkpoint of a laser session: 100 KB of engine state and 25 new poses.
void BM_Checkpoint(benchmark::State& state) {
  const std::string db = FreshDatabase(state);
  if (db.empty()) return;
  auto store = storage::OpenSlamStore(db);
  if (!store.ok()) return state.SkipWithError(std::string(store.status().message()).c_str());
  storage::SlamSessionRecord session;
  session.id = "0123456789abcdef0123456789abcdef";
  session.robot_id = "r1";
  session.config = "config";
  (*store)->CreateSession(session).IgnoreError();
  int64_t seq = 0;
  for (auto _ : state) {
    storage::SlamCheckpoint checkpoint;
    checkpoint.state.assign(100000, 'e');
    checkpoint.scans_processed = seq;
    for (int i = 0; i < 25; ++i, ++seq) {
      storage::TrajectoryPoseRecord pose;
      pose.seq = seq;
      pose.stamp = static_cast<double>(seq);
      checkpoint.new_poses.push_back(pose);
    }
    if (absl::Status s = (*store)->WriteCheckpoint(session.id, checkpoint); !s.ok()) {
      return state.SkipWithError(std::string(s.message()).c_str());
    }
  }
}
BENCHMARK(BM_Checkpoint)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(300);

// The check every authenticated call makes.
void BM_Authenticate(benchmark::State& state) {
  const std::string db = FreshDatabase(state);
  if (db.empty()) return;
  auto store = storage::OpenTokenStore(db);
  if (!store.ok()) return state.SkipWithError(std::string(store.status().message()).c_str());
  auto token = (*store)->CreateToken("robot", "robot", storage::TokenRole::kRobot, std::nullopt);
  if (!token.ok()) return state.SkipWithError(std::string(token.status().message()).c_str());
  for (auto _ : state) {
    benchmark::DoNotOptimize((*store)->Authenticate(token->secret, 1e9).ok());
  }
}
BENCHMARK(BM_Authenticate)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace waymark::bench

BENCHMARK_MAIN();

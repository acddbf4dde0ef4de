// waymark-server: the gRPC service robots talk to.
//
//   waymark-server [--listen 127.0.0.1:50051] [--db ./var/waymark.db] [--threads N]
//                  [--max-message-mb 32] [--slam-queue 64] [--slam-workers N]
//                  [--slam-checkpoint-seconds 30] [--max-sessions 64]
//
// Prints "waymark-server listening on HOST:PORT" once it accepts calls (port 0 picks a free port).
// SIGINT/SIGTERM: stop accepting, let in-flight calls finish (up to --shutdown-grace seconds),
// then checkpoint every SLAM session in memory and close the database.

#include <malloc.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <thread>

#include <CLI/CLI.hpp>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "server/service/crossing_registry.h"
#include "server/service/crossing_service.h"
#include "server/service/slam_registry.h"
#include "server/service/slam_service.h"
#include "storage/crossing_store.h"
#include "storage/slam_store.h"

namespace {

std::atomic<int> g_signal{0};

void OnSignal(int signal) { g_signal = signal; }

struct ServerFlags {
  std::string listen = "127.0.0.1:50051";
  std::string db = "./var/waymark.db";
  int threads = 0;  // 0: gRPC's default (grows with load)
  int max_message_mb = 32;
  double shutdown_grace_s = 10;
  waymark::service::SlamRegistryOptions slam;
};

// Keepalive for robots on Wi-Fi: ping idle connections so dead links are noticed in seconds, and
// accept the clients' own pings (client library: every 20 s) without calling them abusive.
void ConfigureChannel(grpc::ServerBuilder* builder, const ServerFlags& flags) {
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, 30000);
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  builder->AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder->AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10000);
  builder->AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 0);
  const int max_bytes = flags.max_message_mb * 1024 * 1024;
  builder->SetMaxReceiveMessageSize(max_bytes);
  builder->SetMaxSendMessageSize(max_bytes);
  if (flags.threads > 0) {
    grpc::ResourceQuota quota("waymark");
    quota.SetMaxThreads(flags.threads);
    builder->SetResourceQuota(quota);
  }
}

int Run(const ServerFlags& flags) {
  spdlog::info("opening database {}", flags.db);
  auto store = waymark::storage::OpenSqliteCrossingStore(flags.db);
  if (!store.ok()) {
    spdlog::error("cannot open database {}: {}", flags.db, store.status().ToString());
    return 2;
  }
  const auto load_start = std::chrono::steady_clock::now();
  auto registry = waymark::service::CrossingRegistry::Load(std::move(*store));
  if (!registry.ok()) {
    spdlog::error("cannot load crossing databases: {}", registry.status().ToString());
    return 2;
  }
  // Loading frees the rows it read; hand that memory back to the system (glibc keeps it).
  malloc_trim(0);
  const auto databases = (*registry)->ListDatabases();
  int views = 0;
  for (const auto& db : databases->databases()) views += db.views();
  spdlog::info("loaded {} crossing databases ({} views) in {:.1f} s",
               databases->databases_size(), views,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count());

  auto slam_store = waymark::storage::OpenSqliteSlamStore(flags.db);
  if (!slam_store.ok()) {
    spdlog::error("cannot open database {}: {}", flags.db, slam_store.status().ToString());
    return 2;
  }
  auto slam_registry = waymark::service::SlamRegistry::Create(std::move(*slam_store), flags.slam);
  if (!slam_registry.ok()) {
    spdlog::error("cannot start SLAM sessions: {}", slam_registry.status().ToString());
    return 2;
  }

  waymark::service::CrossingServiceImpl crossing_service(registry->get());
  waymark::service::SlamServiceImpl slam_service(slam_registry->get());
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(flags.listen, grpc::InsecureServerCredentials(), &port);
  ConfigureChannel(&builder, flags);
  builder.RegisterService(&crossing_service);
  builder.RegisterService(&slam_service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    spdlog::error("cannot listen on {} (address in use or invalid?)", flags.listen);
    return 2;
  }
  server->GetHealthCheckService()->SetServingStatus("waymark.v1.CrossingService", true);
  server->GetHealthCheckService()->SetServingStatus("waymark.v1.SlamService", true);
  const std::string host = flags.listen.substr(0, flags.listen.rfind(':'));
  std::printf("waymark-server listening on %s:%d\n", host.c_str(), port);
  std::fflush(stdout);
  spdlog::info("try: waymark --server {}:{} db list   (or grpcurl -plaintext {}:{} list)", host,
               port, host, port);

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  while (g_signal == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("signal {}: shutting down, letting in-flight calls finish", g_signal.load());
  server->GetHealthCheckService()->SetServingStatus(false);
  const auto deadline = std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<int>(flags.shutdown_grace_s * 1000));
  server->Shutdown(deadline);
  server->Wait();
  // Streams have ended (their accepted messages answered): save every session in memory.
  if (absl::Status s = (*slam_registry)->Shutdown(); !s.ok()) {
    spdlog::error("SLAM checkpoint at shutdown failed: {}", s.ToString());
  }
  spdlog::info("stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ServerFlags flags;
  CLI::App app{"waymark-server: crossing recognition and SLAM sessions for robots, over gRPC"};
  app.add_option("--listen", flags.listen, "address to listen on (port 0 picks a free port)")
      ->capture_default_str();
  app.add_option("--db", flags.db, "SQLite database file (created if missing)")
      ->capture_default_str();
  app.add_option("--threads", flags.threads, "max request threads (0 = gRPC default)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-message-mb", flags.max_message_mb, "largest accepted message in MiB")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--shutdown-grace", flags.shutdown_grace_s,
                 "seconds in-flight calls get to finish on SIGINT/SIGTERM")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--slam-queue", flags.slam.queue_capacity,
                 "SLAM messages waiting per session; more get RESOURCE_EXHAUSTED")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--slam-workers", flags.slam.workers,
                 "threads processing SLAM sessions (0 = hardware threads)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  app.add_option("--slam-checkpoint-seconds", flags.slam.checkpoint_seconds,
                 "checkpoint a SLAM session with new data this often (0 = only on close/shutdown)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--slam-checkpoint-scans", flags.slam.checkpoint_scans,
                 "also checkpoint a SLAM session every N processed scans (0 = off)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-sessions", flags.slam.max_sessions,
                 "open SLAM sessions this server holds; CreateSession beyond gets RESOURCE_EXHAUSTED")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  // glibc gives every thread that allocates its own arena and keeps freed memory in each; with
  // a request thread per call that grows the heap well past what the databases hold. Two arenas
  // are plenty for the request threads of a 2-8 core server.
  mallopt(M_ARENA_MAX, 2);
  // Logs go to stderr; stdout carries only the "listening on" line that scripts wait for.
  spdlog::set_default_logger(spdlog::stderr_color_mt("waymark"));
  return Run(flags);
}

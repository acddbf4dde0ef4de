// waymark-server: the gRPC service robots talk to.
//
//   waymark-server [--listen 127.0.0.1:50051] [--db ./var/waymark.db] [--threads N]
//                  [--insecure-dev | --tls-cert F --tls-key F [--tls-client-ca F] | --allow-plaintext]
//                  [--max-message-mb 32] [--max-streams-per-robot 8] [--stream-idle-seconds 300]
//                  [--metrics-listen HOST:PORT] [--live [HOST:]PORT] [--slam-queue 64]
//                  [--slam-workers N] [--slam-checkpoint-seconds 30] [--max-sessions 64]
//                  [--slam-journal true] [--slam-checkpoint-journal-mb 64] [--slam-map-tie true] [--slam-map-tie-outvote true] [--slam-map-tie-verify true] [--slam-map-follow true] [--slam-map-follow-windows uncertainty] [--slam-map-graph true] [--slam-map-feed-seconds 1]
//   waymark-server --db FILE token create NAME --role admin|mapper|robot|viewer [--robot-id ID]
//   waymark-server --db FILE token list | token revoke NAME
//
// Every call needs a bearer token (server/service/auth/access_policy.h) unless --insecure-dev, which is
// only accepted on loopback. Plaintext is only served on loopback unless --allow-plaintext.
// Prints "waymark-server listening on HOST:PORT" once it accepts calls (port 0 picks a free port).
// SIGINT/SIGTERM: stop accepting, checkpoint every SLAM session in memory, end the open streams
// (UNAVAILABLE "server shutting down"; robots resume their sessions once the server is back), let
// the other in-flight calls finish (up to --shutdown-grace seconds) and close the database.
// SIGPIPE is ignored: a log reader that went away (stderr piped into a `tee` that was closed)
// must not kill the server before its shutdown checkpoint.

#include <malloc.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <optional>
#include <random>
#include <thread>

#include <CLI/CLI.hpp>
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "server/service/auth/authenticator.h"
#include "server/service/operations/call_interceptor.h"
#include "server/service/crossing/crossing_fleet_sync.h"
#include "server/service/crossing/crossing_registry.h"
#include "server/service/crossing_service.h"
#include "server/service/runtime/idle_stream_reaper.h"
#include "server/service/runtime/memory_trimmer.h"
#include "server/service/operations/metrics.h"
#include "server/service/live/live_server.h"
#include "server/service/slam/slam_registry.h"
#include "server/service/runtime/server_channel.h"
#include "server/service/auth/server_security.h"
#include "server/service/slam_service.h"
#include "server/service/runtime/stream_limiter.h"
#include "server/service/token_service.h"
#include "server/token_admin.h"
#include "storage/crossing_store.h"
#include "storage/database_lock.h"
#include "storage/open_stores.h"
#include "storage/slam_store.h"
#include "storage/token_store.h"

namespace {

std::atomic<int> g_signal{0};

void OnSignal(int signal) { g_signal = signal; }

struct ServerFlags {
  std::string listen = "127.0.0.1:50051";
  std::string db = "./var/waymark.db";
  std::string metrics_listen;  // "" = no metrics endpoint
  std::string live;            // "" = no live view (docs/live-view.md)
  waymark::service::live::LiveOptions live_options;
  // Where robots reach this server, named when another server redirects a robot here (a fleet on
  // PostgreSQL); "" = the --listen address.
  std::string advertise;
  double session_lease_seconds = 15;
  int threads = 0;  // 0: gRPC's default (grows with load)
  int max_message_mb = 32;
  double shutdown_grace_s = 10;
  int max_streams_per_robot = 8;
  double stream_idle_seconds = 300;
  waymark::service::SecurityOptions security;
  waymark::service::SlamRegistryOptions slam;
  int slam_checkpoint_journal_mb = 64;
};

// With auth on and no live admin token, nobody can manage tokens over the API: say how to start.
void HintFirstToken(waymark::storage::TokenStore& tokens, const ServerFlags& flags) {
  auto list = tokens.ListTokens();
  if (!list.ok()) return;
  for (const auto& token : *list) {
    if (token.role == waymark::storage::TokenRole::kAdmin && !token.revoked_at.has_value()) return;
  }
  spdlog::warn(
      "no admin token yet: every call will be UNAUTHENTICATED until you create tokens, e.g. "
      "`waymark-server --db {} token create admin --role admin` (prints the secret once; then "
      "`waymark --token SECRET token create ROBOT --role robot`)",
      waymark::storage::PrintableDatabase(flags.db));
}

// This process's id in SLAM session leases: random, so a restarted server is a new holder.
std::string RandomServerId() {
  std::random_device device;
  return absl::StrCat(absl::Hex(device(), absl::kZeroPad8), absl::Hex(device(), absl::kZeroPad8));
}

int Run(const ServerFlags& flags) {
  auto credentials = waymark::service::MakeServerCredentials(flags.listen, flags.security);
  if (!credentials.ok()) {
    spdlog::error("{}", std::string(credentials.status().message()));
    return 2;
  }
  const std::string db_name = waymark::storage::PrintableDatabase(flags.db);
  // One serving process per SQLite file: two servers would each cache the crossing views and SLAM
  // sessions and overwrite each other's checkpoints. PostgreSQL is how several servers share one
  // database (docs/scale-out.md).
  std::optional<waymark::storage::DatabaseLock> db_lock;
  if (!waymark::storage::IsPostgresDatabase(flags.db)) {
    auto locked = waymark::storage::DatabaseLock::Acquire(flags.db);
    if (!locked.ok()) {
      spdlog::error("{}", std::string(locked.status().message()));
      return 2;
    }
    db_lock.emplace(std::move(*locked));
  }
  spdlog::info("opening database {}", db_name);
  auto stores = waymark::storage::OpenStores(flags.db);
  if (!stores.ok()) {
    spdlog::error("cannot open database {}: {}", db_name, stores.status().ToString());
    return 2;
  }
  const auto load_start = std::chrono::steady_clock::now();
  auto registry = waymark::service::CrossingRegistry::Load(std::move(stores->crossing));
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

  // With PostgreSQL, other servers may enroll into the same databases: follow them.
  auto fleet_sync = waymark::service::CrossingFleetSync::Start(registry->get());
  if (fleet_sync != nullptr) {
    spdlog::info("following the other servers of {} (LISTEN/NOTIFY, and a sync every 5 s)",
                 db_name);
  }

  waymark::service::SlamRegistryOptions slam_options = flags.slam;
  slam_options.checkpoint_journal_bytes = size_t(flags.slam_checkpoint_journal_mb) << 20;
  if (waymark::storage::IsPostgresDatabase(flags.db)) {
    // Other servers share the sessions: each is served by the one holding its lease.
    slam_options.lease.owner = RandomServerId();
    slam_options.lease.address = flags.advertise.empty() ? flags.listen : flags.advertise;
    slam_options.lease.ttl_seconds = flags.session_lease_seconds;
    spdlog::info("SLAM sessions leased as server {} at {} ({} s leases)", slam_options.lease.owner,
                 slam_options.lease.address, slam_options.lease.ttl_seconds);
  }
  // Freed heap back to the system after bursts and after SLAM sessions leave memory; declared
  // before the registry, whose sessions tell it when they go (until the registry is destroyed).
  waymark::service::MemoryTrimmer memory_trimmer;
  auto slam_registry = waymark::service::SlamRegistry::Create(std::move(stores->slam), slam_options,
                                                              std::move(stores->map));
  if (!slam_registry.ok()) {
    spdlog::error("cannot start SLAM sessions: {}", slam_registry.status().ToString());
    return 2;
  }
  {
    // A closed session's engine is freed, but glibc keeps the pages in its arenas: give them back.
    waymark::service::SlamObserver trim_after_release;
    trim_after_release.on_released = [&memory_trimmer](const std::string&) {
      memory_trimmer.TrimSoon();
    };
    (*slam_registry)->AddObserver(std::move(trim_after_release));
  }

  // Declared after the registries it reads, so it stops serving before they go away.
  std::unique_ptr<waymark::service::Metrics> metrics;
  if (!flags.metrics_listen.empty()) {
    auto started = waymark::service::StartMetrics(
        flags.metrics_listen, {registry->get(), slam_registry->get(),
         waymark::storage::IsPostgresDatabase(flags.db) ? std::string() : flags.db});
    if (!started.ok()) {
      spdlog::error("{}", std::string(started.status().message()));
      return 2;
    }
    metrics = std::move(*started);
  }

  std::shared_ptr<waymark::storage::TokenStore> tokens = std::move(stores->token);
  std::unique_ptr<waymark::service::Authenticator> auth;
  if (flags.security.insecure_dev) {
    spdlog::warn("--insecure-dev: authentication is OFF (loopback only); do not use on a robot fleet");
    auth = waymark::service::Authenticator::AuthOff();
  } else {
    HintFirstToken(*tokens, flags);
    auth = waymark::service::Authenticator::WithTokens(tokens);
  }
  // The live view: after the authenticator it asks, declared after the registries it reads so it
  // stops first.
  std::unique_ptr<waymark::service::live::LiveServer> live;
  if (!flags.live.empty()) {
    waymark::service::live::LiveOptions live_options = flags.live_options;
    if (absl::Status s = waymark::service::live::ParseLiveAddress(flags.live, &live_options);
        !s.ok()) {
      spdlog::error("{}", std::string(s.message()));
      return 2;
    }
    auto started = waymark::service::live::LiveServer::Start(
        live_options, slam_registry->get(), registry->get(), auth.get());
    if (!started.ok()) {
      spdlog::error("{}", std::string(started.status().message()));
      return 2;
    }
    live = std::move(*started);
    spdlog::info("live view on http://{}:{}/ (Foxglove: ws://{}:{}; {})", live->host(),
                 live->port(), live->host(), live->port(),
                 flags.security.insecure_dev ? "auth OFF" : "a viewer token as ?token=");
  }
  waymark::service::StreamLimiter streams(flags.max_streams_per_robot);
  waymark::service::IdleStreamReaper idle_streams(flags.stream_idle_seconds);

  waymark::service::CrossingServiceImpl crossing_service(registry->get(), auth.get(), &streams,
                                                        &idle_streams);
  waymark::service::SlamServiceImpl slam_service(slam_registry->get(), auth.get(), &streams,
                                                &idle_streams);
  waymark::service::TokenServiceImpl token_service(tokens, auth.get());
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(flags.listen, *credentials, &port);
  waymark::service::ConfigureServerChannel(&builder, {flags.max_message_mb, flags.threads});
  builder.RegisterService(&crossing_service);
  builder.RegisterService(&slam_service);
  builder.RegisterService(&token_service);
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(waymark::service::MakeCallInterceptorFactory(metrics.get()));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    spdlog::error("cannot listen on {} (address in use or invalid?)", flags.listen);
    return 2;
  }
  server->GetHealthCheckService()->SetServingStatus("waymark.v1.CrossingService", true);
  server->GetHealthCheckService()->SetServingStatus("waymark.v1.SlamService", true);
  server->GetHealthCheckService()->SetServingStatus("waymark.v1.TokenService", true);
  const std::string host = flags.listen.substr(0, flags.listen.rfind(':'));
  if (flags.advertise.empty()) (*slam_registry)->set_lease_address(absl::StrCat(host, ":", port));
  std::printf("waymark-server listening on %s:%d\n", host.c_str(), port);
  spdlog::info("{} on {}:{}; auth {}", flags.security.tls_cert.empty() ? "plaintext" : "TLS", host,
               port, flags.security.insecure_dev ? "OFF (--insecure-dev)" : "by bearer token");
  std::fflush(stdout);
  spdlog::info("try: waymark --server {}:{} db list   (or grpcurl -plaintext {}:{} list)", host,
               port, host, port);

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  while (g_signal == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("signal {}: shutting down: saving the SLAM sessions, ending the streams, letting "
               "in-flight calls finish",
               g_signal.load());
  server->GetHealthCheckService()->SetServingStatus(false);
  if (live != nullptr) live->Stop();  // viewers go first: they only watch
  const auto deadline = std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<int>(flags.shutdown_grace_s * 1000));
  // Shutdown() refuses new calls at once and waits for the running ones (up to the grace); it
  // runs beside the rest, which ends the calls that would never end on their own.
  std::thread stop_serving([&] { server->Shutdown(deadline); });
  // Sessions refuse new messages, answer the accepted ones and are saved; then the streams that
  // fed them (and cameras' recognition streams) end, telling their robots why; enrollment
  // uploads finish within the grace.
  if (absl::Status s = (*slam_registry)->Shutdown(); !s.ok()) {
    spdlog::error("SLAM checkpoint at shutdown failed: {}", s.ToString());
  }
  idle_streams.EndAll(grpc::StatusCode::UNAVAILABLE,
                      "server shutting down (sessions saved): resume once it is back");
  stop_serving.join();
  server->Wait();
  spdlog::info("stopped");
  return 0;
}

// protobuf prints a line on stderr for every request string that is not UTF-8 (the client's
// error, already answered INVALID_ARGUMENT): 15,827 such lines in the issue 21 campaign, which
// trip alerting on a server's error output. They go to the log at debug level; anything else
// protobuf reports stays a warning.
void ProtobufLogToSpdlog(google::protobuf::LogLevel level, const char* file, int line,
                         const std::string& message) {
  const bool clients_bytes = message.find("invalid UTF-8") != std::string::npos;
  const spdlog::level::level_enum to =
      clients_bytes ? spdlog::level::debug
      : level >= google::protobuf::LOGLEVEL_WARNING ? spdlog::level::warn
                                                     : spdlog::level::info;
  spdlog::log(to, "protobuf {}:{}: {}", file, line, message);
}

}  // namespace

int main(int argc, char** argv) {
  // Writes to a closed pipe (a log reader gone) fail with EPIPE instead of killing the server.
  std::signal(SIGPIPE, SIG_IGN);
  ServerFlags flags;
  CLI::App app{"waymark-server: crossing recognition and SLAM sessions for robots, over gRPC"};
  app.add_option("--listen", flags.listen, "address to listen on (port 0 picks a free port)")
      ->capture_default_str();
  app.add_option("--db", flags.db, "SQLite database file (created if missing), or a PostgreSQL URI "
                 "postgresql://USER@HOST:PORT/DBNAME shared by several servers (password from "
                 "PGPASSWORD or PGPASSFILE, never on the command line)")
      ->envname("WAYMARK_DB")
      ->capture_default_str();
  app.add_flag("--insecure-dev", flags.security.insecure_dev,
               "development only: no authentication, plaintext; refused unless --listen is loopback");
  app.add_option("--tls-cert", flags.security.tls_cert, "PEM certificate chain: serve TLS")
      ->envname("WAYMARK_TLS_CERT");
  app.add_option("--tls-key", flags.security.tls_key, "PEM private key of --tls-cert")
      ->envname("WAYMARK_TLS_KEY");
  app.add_option("--tls-client-ca", flags.security.tls_client_ca,
                 "PEM CA: require client certificates signed by it (mutual TLS)")
      ->envname("WAYMARK_TLS_CLIENT_CA");
  app.add_flag("--allow-plaintext", flags.security.allow_plaintext,
               "serve plaintext on a non-loopback address (TLS terminated in front of the server)");
  app.add_option("--max-streams-per-robot", flags.max_streams_per_robot,
                 "streams one robot may hold open at once; more get RESOURCE_EXHAUSTED (0 = no limit)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  app.add_option("--stream-idle-seconds", flags.stream_idle_seconds,
                 "end a client stream that sent nothing for this long (0 = never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--threads", flags.threads, "max request threads (0 = gRPC default)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-message-mb", flags.max_message_mb, "largest accepted message in MiB")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--shutdown-grace", flags.shutdown_grace_s,
                 "seconds in-flight calls get to finish on SIGINT/SIGTERM (open streams end as "
                 "soon as their sessions are saved)")
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
  app.add_option("--slam-journal", flags.slam.journal,
                 "store every accepted SLAM message before processing it, so that a session "
                 "resumed after a crash has everything the server answered (false: it goes back "
                 "to its last checkpoint)")
      ->capture_default_str();
  app.add_option("--slam-map-tie", flags.slam.map_tie,
                 "find a robot that joined a shared map in it from its scans and tie it in "
                 "(false: only a session created with an initial map pose is tied in)")
      ->capture_default_str();
  app.add_option("--slam-map-tie-outvote", flags.slam.map_tie_outvote,
                 "tie a robot into a shared map only when more of its unique matches agree with "
                 "the tie than disagree with it (false: the first two that agree tie it)")
      ->capture_default_str();
  app.add_option("--slam-map-tie-verify", flags.slam.map_tie_verify,
                 "keep a robot's tie into a shared map only when the map's self-check with the "
                 "robot placed there finds no new contradicting area (false: every tie found is "
                 "kept)")
      ->capture_default_str();
  app.add_option("--slam-map-follow", flags.slam.map_follow,
                 "after a robot is tied into a shared map, keep matching its scans against the "
                 "other robots' map in local windows, so that its drift does not carry it off "
                 "(false: the origin found at the tie holds for all its poses)")
      ->capture_default_str();
  app.add_option("--slam-map-graph", flags.slam.map_graph,
                 "place a shared map's trajectories by one pose graph over all of them, so that "
                 "a robot that drives a loop another robot left open closes it (false: each "
                 "followed robot is bent to meet the others, which hold still)")
      ->capture_default_str();
  app.add_option_function<std::string>(
         "--slam-map-follow-windows",
         [&flags](const std::string& windows) {
           using Windows = waymark::service::SlamRegistryOptions::FollowWindows;
           flags.slam.map_follow_windows = windows == "wide"          ? Windows::kWide
                                           : windows == "uncertainty" ? Windows::kUncertainty
                                                                      : Windows::kNarrow;
         },
         "how far a followed robot is looked for: uncertainty (the default: as far as the "
         "robot's own and the map's chain uncertainty reach, at least 2 m of travel's drift and "
         "up to 30 m), narrow (at most 2 m and 0.4 rad from where its last match puts it) or wide "
         "(as far as the other robots' map may have drifted by its path length, up to 30 m: a "
         "robot can be placed in a look-alike room); docs/laser-slam.md")
      ->check(CLI::IsMember({"narrow", "wide", "uncertainty"}))
      ->default_str("uncertainty");
  app.add_option("--slam-map-feed-seconds", flags.slam.map_feed_seconds,
                 "on a fleet, publish a robot's nodes for the server that owns its shared map at "
                 "most this often, so that the owner ties and follows it as it goes (0: the owner "
                 "reads the robot's checkpoints only)")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  app.add_option("--slam-checkpoint-journal-mb", flags.slam_checkpoint_journal_mb,
                 "also checkpoint a SLAM session once its journal since the last checkpoint "
                 "holds this many MB (bounds the replay after a crash)")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  app.add_option("--advertise", flags.advertise,
                 "HOST:PORT robots reach this server at, when several servers share a PostgreSQL "
                 "database (another server names it to a robot whose session this one serves; "
                 "default: the --listen address)")
      ->envname("WAYMARK_ADVERTISE");
  app.add_option("--session-lease-seconds", flags.session_lease_seconds,
                 "with PostgreSQL: how long a SLAM session stays with a server that stops renewing "
                 "its lease (a dead server's robots move to another after this)")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  app.add_option("--metrics-listen", flags.metrics_listen,
                 "serve Prometheus metrics at http://IPV4:PORT/metrics (empty = off; port 0 picks one)");
  app.add_option("--live", flags.live,
                 "serve the live view at PORT or HOST:PORT (a bare port: loopback only): the "
                 "Foxglove WebSocket protocol and a page of its own (docs/live-view.md; empty = "
                 "off; port 0 picks one); needs a viewer token unless --insecure-dev");
  app.add_option("--live-grid-resolution", flags.live_options.grid_resolution,
                 "m per cell of the live view's occupancy grids (coarser for larger maps)")
      ->check(CLI::Range(0.01, 1.0))
      ->capture_default_str();
  app.add_option("--live-stall-seconds", flags.live_options.stall_seconds,
                 "a live viewer that takes nothing for this long while messages wait is dropped "
                 "(slow link, or it stopped reading)")
      ->check(CLI::Range(0.5, 3600.0))
      ->capture_default_str();
  app.add_option("--live-max-viewers", flags.live_options.max_viewers,
                 "viewers the live view serves at once; more get HTTP 503")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--max-sessions", flags.slam.max_sessions,
                 "open SLAM sessions this server holds; CreateSession beyond gets RESOURCE_EXHAUSTED")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  waymark::server::TokenAdminFlags token_flags;
  CLI::App* token_group = waymark::server::AddTokenAdminCommands(app, &token_flags);
  CLI11_PARSE(app, argc, argv);
  if (token_group->parsed()) return waymark::server::RunTokenAdmin(token_group, token_flags, flags.db);
  // glibc gives every thread that allocates its own arena and keeps freed memory in each; with
  // a request thread per call that grows the heap well past what the databases hold. Two arenas
  // are plenty for the request threads of a 2-8 core server.
  mallopt(M_ARENA_MAX, 2);
  // glibc serves a block of 128 KB or more with its own mmap, but after the first such block is
  // freed it raises that threshold to the block's size (up to 32 MB) and serves the next ones
  // from the arenas, which keep them: after a burst of large requests (8 clients x 24 MiB
  // images) the server stayed 25-50 MB above its idle size for good. A fixed threshold keeps
  // every large buffer (request bytes, decoded images, checkpoints) in its own mapping, which
  // goes back to the system the moment it is freed; measured with waymark-memory-burst
  // (docs/operations.md, "Memory").
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  // Logs go to stderr; stdout carries only the "listening on" line that scripts wait for.
  spdlog::set_default_logger(spdlog::stderr_color_mt("waymark"));
  google::protobuf::SetLogHandler(&ProtobufLogToSpdlog);
  return Run(flags);
}

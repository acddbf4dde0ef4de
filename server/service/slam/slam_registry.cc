#include "server/service/slam/slam_registry.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/service/slam/exploration_team.h"
#include "server/service/slam/laser_session_engine.h"
#include "server/service/slam/map_registry.h"
#include "server/service/slam/map_tie_worker.h"
#include "server/service/slam/session_lifecycle.h"
#include "server/service/slam/session_persistence.h"
#include "server/service/slam/session_queries.h"
#include "server/service/slam/session_scheduler.h"
#include "server/service/slam/session_streams.h"
#include "server/service/slam/session_table.h"
#include "server/service/slam/slam_journal.h"

namespace waymark::service {

absl::StatusOr<std::unique_ptr<SlamRegistry>> SlamRegistry::Create(
    std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options,
    std::unique_ptr<storage::MapStore> maps) {
  if (store == nullptr) return absl::InvalidArgumentError("no SLAM store");
  if (options.queue_capacity < 1 || options.queue_capacity > 100000) {
    return absl::InvalidArgumentError(absl::StrCat("SLAM queue capacity must be in [1, 100000], got ",
                                                   options.queue_capacity));
  }
  if (options.workers < 0 || options.workers > 256) {
    return absl::InvalidArgumentError(
        absl::StrCat("SLAM workers must be in [0, 256] (0 = hardware threads), got ",
                     options.workers));
  }
  if (!std::isfinite(options.checkpoint_seconds) || options.checkpoint_seconds < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SLAM checkpoint interval must be >= 0 s (0 = off), got ", options.checkpoint_seconds));
  }
  if (options.checkpoint_scans < 0) {
    return absl::InvalidArgumentError("SLAM checkpoint scan count must be >= 0 (0 = off)");
  }
  if (options.max_sessions < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("max sessions must be at least 1, got ", options.max_sessions));
  }
  if (options.max_batch < 1) return absl::InvalidArgumentError("max_batch must be at least 1");
  if (options.max_queued_frame_bytes < 1) {
    return absl::InvalidArgumentError("max_queued_frame_bytes must be at least 1");
  }
  std::unique_ptr<SlamRegistry> registry(
      new SlamRegistry(std::move(store), options, std::move(maps)));
  if (absl::Status s = registry->maps_->Load(); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat("cannot load the SLAM maps: ", s.message()));
  }
  return registry;
}

SlamRegistry::SlamRegistry(std::unique_ptr<storage::SlamStore> store,
                           const SlamRegistryOptions& options,
                           std::unique_ptr<storage::MapStore> maps)
    : options_(options), store_(std::move(store)), map_store_(std::move(maps)),
      leases_(store_.get(), options.lease) {
  if (options_.journal) {
    journal_ = std::make_unique<SlamJournal>(store_.get(), [this] { return leases_.owner(); });
  }
  table_ = std::make_unique<SessionTable>();
  persistence_ = std::make_unique<SessionPersistence>(store_.get(), options_, &leases_);
  lifecycle_ = std::make_unique<SessionLifecycle>(store_.get(), options_, &shutting_down_,
                                                  &leases_, table_.get(), persistence_.get());
  queries_ = std::make_unique<SessionQueries>(store_.get(), table_.get(), persistence_.get());
  // The workers only call into the streams for messages the streams queued: they start idle.
  int workers = options_.workers;
  if (workers == 0) workers = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  scheduler_ = std::make_unique<SessionScheduler>(
      workers, options_.max_batch,
      [this](SlamSession& session, QueuedMessage& message, const SlamUpdateSink& sink) {
        streams_->Process(session, message, sink);
      });
  streams_ = std::make_unique<SessionStreams>(options_, &shutting_down_, journal_.get(),
                                              scheduler_.get(), persistence_.get());
  // With several servers on one database, a session may have joined its map on another one, and
  // a map is tied and followed by the server holding its lease.
  maps_ = std::make_unique<MapRegistry>(map_store_.get(), &leases_);
  maps_->set_map_graph(options_.map_graph);
  team_ = std::make_shared<ExplorationTeam>(*maps_);
  if (map_store_ != nullptr && options_.map_tie) {
    // Ties robots into their maps, on its own thread (map_tie_worker.h).
    MapTieWorker::Sources sources;
    sources.maps_to_tie = [this] { return maps_->MapsToTie(); };
    sources.nodes = [this](const std::string& id) { return queries_->TrajectoryNodesOf(id); };
    sources.resident = [this](const std::string& id) { return queries_->IsResident(id); };
    sources.own = [this](const std::string& map) { return maps_->Own(map); };
    sources.samples = [this](const std::string& id) { return maps_->FollowedSamples(id); };
    sources.tie = [this](const std::string& map, const std::string& id,
                         const storage::MapTie& tie) { return maps_->Tie(map, id, tie); };
    sources.maps_to_follow = [this] { return maps_->MapsToFollow(); };
    sources.follow = [this](const std::string& map, const std::string& id,
                            const std::vector<laser_slam::OriginSample>& samples,
                            const laser_slam::FollowProgress& progress) {
      return maps_->Follow(map, id, samples, progress);
    };
    sources.searched = [this](const std::string& id, const laser_slam::TieProgress& progress) {
      maps_->Searched(id, progress);
    };
    if (leases_.enabled() && options_.map_feed_seconds > 0.0) {
      // Only a fleet has robots on one server and their map's owner on another.
      storage::MapStore* store = map_store_.get();
      sources.publish = [store](const std::string& id, const storage::TrajectoryFeedUpdate& update) {
        return store->PublishTrajectoryFeed(id, update);
      };
      sources.maps_to_publish = [this] { return maps_->MapsWithOthers(); };
      sources.holds = [this](const std::string& map) { return maps_->Holds(map); };
      sources.read_feed = [store](const std::string& id, int64_t after_version,
                                  int64_t after_scan) {
        return store->ReadTrajectoryFeed(id, after_version, after_scan);
      };
    }
    MapTieWorker::Options worker_options;
    worker_options.follow = options_.map_follow;
    worker_options.tie.outvote_disagreements = options_.map_tie_outvote;
    worker_options.verify_ties = options_.map_tie_verify;
    worker_options.feed_seconds = options_.map_feed_seconds;
    using Windows = SlamRegistryOptions::FollowWindows;
    if (options_.map_follow_windows == Windows::kWide) {
      worker_options.follow_options = laser_slam::WideFollowWindows(worker_options.follow_options);
    } else if (options_.map_follow_windows == Windows::kNarrow) {
      worker_options.follow_options =
          laser_slam::NarrowFollowWindows(worker_options.follow_options);
    }
    tie_worker_ = std::make_unique<MapTieWorker>(std::move(sources), worker_options);
  }
  // Idle sessions' time-based checkpoints (a processed scan checks its own session).
  if (options_.checkpoint_seconds > 0) {
    scheduler_->Every(std::chrono::duration<double>(
                          std::clamp(options_.checkpoint_seconds / 4.0, 0.05, 5.0)),
                      [this] { persistence_->CheckpointIdle(*table_); });
  }
  if (leases_.enabled()) {
    scheduler_->Every(std::chrono::duration<double>(std::max(0.05, options_.lease.ttl_seconds / 3.0)),
                      [this] { lifecycle_->RenewLeases(); });
  }
}

SlamRegistry::~SlamRegistry() {
  absl::Status status = Shutdown();
  if (!status.ok()) spdlog::error("SLAM shutdown: {}", status.ToString());
}

absl::StatusOr<v1::Session> SlamRegistry::CreateSession(const v1::CreateSessionRequest& request) {
  if (request.has_initial_map_pose()) {
    const v1::Pose2D& pose = request.initial_map_pose();
    if (request.map().empty()) {
      return absl::InvalidArgumentError(
          "initial_map_pose is where the robot starts in a shared map: set map too");
    }
    if (!std::isfinite(pose.x()) || !std::isfinite(pose.y()) || !std::isfinite(pose.theta()) ||
        std::abs(pose.x()) > 1e6 || std::abs(pose.y()) > 1e6) {
      return absl::InvalidArgumentError(
          "initial_map_pose must be finite, with x and y within 1e6 m");
    }
  }
  if (request.map().empty()) return lifecycle_->CreateSession(request);
  // Refused (bad name, unknown map, a session that cannot be a map's trajectory) before anything
  // is stored.
  if (absl::Status s = maps_->CheckJoin(request); !s.ok()) return s;
  absl::StatusOr<v1::Session> session = lifecycle_->CreateSession(request);
  if (!session.ok()) return session;
  if (absl::StatusOr<v1::Map> joined = maps_->Join(request.map(), session->session_id());
      !joined.ok()) {
    // The map went meanwhile (deleted by another call): no session half in it.
    (void)lifecycle_->DeleteSession(session->session_id(), /*force=*/true);
    return joined.status();
  }
  session->set_map(request.map());
  if (request.has_initial_map_pose()) {
    // The session's frame starts at its first pose, so its origin in the map frame is the
    // robot's start there. Stored as a found tie would be (the first robot's too: the map frame
    // is then wherever its given start puts it).
    const v1::Pose2D& pose = request.initial_map_pose();
    if (absl::Status s = maps_->Tie(request.map(), session->session_id(),
                                    storage::MapTie{pose.x(), pose.y(),
                                                    std::remainder(pose.theta(), 2 * M_PI)});
        !s.ok()) {
      (void)lifecycle_->DeleteSession(session->session_id(), /*force=*/true);
      maps_->SessionDeleted(session->session_id());
      return s;
    }
  }
  return session;
}

absl::StatusOr<v1::Session> SlamRegistry::ImportMap(const v1::ImportMapRequest& request) {
  return lifecycle_->ImportMap(request);
}

absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> SlamRegistry::OpenStream(
    const std::string& session_id, SlamUpdateSink sink, std::function<void()> cancel) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  if (shutting_down_) {
    return absl::UnavailableError("the server is shutting down; resume the session after it restarts");
  }
  bool loaded = false;
  absl::StatusOr<std::shared_ptr<SlamSession>> session =
      lifecycle_->ResidentOrLoad(session_id, &loaded);
  if (!session.ok()) return session.status();
  if (std::shared_ptr<MapMembership> member = maps_->Membership(session_id); member != nullptr) {
    // A session in a map: each answer says where the robot is in the map frame, or that it is
    // not yet in the map.
    sink = [member, sink = std::move(sink)](const v1::SlamUpdate& update) {
      if (update.has_rejection() || !update.has_pose()) return sink(update);
      v1::SlamUpdate decorated = update;
      member->Decorate(&decorated);
      sink(decorated);
    };
    // Its goal layer sees the map's other robots (an active session; the others ignore it).
    // The engine is fixed once the session is built; SetTeam has its own lock.
    if (auto* laser = dynamic_cast<LaserSessionEngine*>((*session)->engine.get())) {
      laser->SetTeam(team_, session_id);
    }
  }
  return streams_->Attach(*session, loaded, std::move(sink), std::move(cancel));
}

absl::StatusOr<v1::Session> SlamRegistry::CloseSession(const std::string& session_id) {
  absl::StatusOr<v1::Session> closed = lifecycle_->CloseSession(session_id);
  if (closed.ok()) closed->set_map(maps_->MapOf(session_id));
  return closed;
}

absl::StatusOr<v1::DeleteSessionResponse> SlamRegistry::DeleteSession(
    const std::string& session_id, bool force) {
  // Known before the delete takes the trajectory row with it (on a fleet the session may have
  // joined its map on another server: this looks it up in the store).
  (void)maps_->Membership(session_id);
  absl::StatusOr<v1::DeleteSessionResponse> deleted = lifecycle_->DeleteSession(session_id, force);
  if (deleted.ok()) {
    deleted->mutable_session()->set_map(maps_->MapOf(session_id));
    maps_->SessionDeleted(session_id);
    team_->Forget(session_id);
  }
  return deleted;
}

absl::StatusOr<v1::Session> SlamRegistry::GetSession(const std::string& session_id) {
  absl::StatusOr<v1::Session> session = queries_->GetSession(session_id);
  if (session.ok()) session->set_map(maps_->MapOf(session_id));
  return session;
}

absl::StatusOr<v1::SegmentMap> SlamRegistry::GetMap(const std::string& session_id) {
  return queries_->GetMap(session_id);
}

absl::StatusOr<v1::Trajectory> SlamRegistry::GetTrajectory(const std::string& session_id) {
  return queries_->GetTrajectory(session_id);
}

absl::StatusOr<v1::OccupancyGrid> SlamRegistry::GetOccupancyGrid(
    const std::string& session_id, std::optional<double> resolution) {
  return queries_->GetOccupancyGrid(session_id, resolution);
}

absl::StatusOr<v1::ListSessionsResponse> SlamRegistry::ListSessions(const std::string& robot_id) {
  absl::StatusOr<v1::ListSessionsResponse> listed = queries_->ListSessions(robot_id);
  if (listed.ok()) {
    for (v1::Session& session : *listed->mutable_sessions()) {
      session.set_map(maps_->MapOf(session.session_id()));
    }
  }
  return listed;
}

absl::StatusOr<v1::Map> SlamRegistry::CreateMap(const std::string& name) {
  return maps_->CreateMap(name);
}

absl::StatusOr<v1::ListMapsResponse> SlamRegistry::ListMaps() { return maps_->ListMaps(); }

absl::StatusOr<v1::DeleteMapResponse> SlamRegistry::DeleteMap(const std::string& name,
                                                              bool force) {
  return maps_->DeleteMap(name, force);
}

namespace {

// A session's scan nodes, as maps read them (their grid, their segments).
MapRegistry::SessionNodes SessionNodesForMaps(SessionQueries& queries) {
  return [&queries](const std::string& session_id) {
    return queries.TrajectoryNodesOf(session_id);
  };
}

}  // namespace

absl::StatusOr<v1::Map> SlamRegistry::GetMapInfo(const std::string& name, bool node_origins) {
  if (!node_origins) return maps_->GetMap(name);
  return maps_->GetMapWithNodeOrigins(name, SessionNodesForMaps(*queries_));
}

absl::StatusOr<v1::MapOccupancyGrid> SlamRegistry::GetMapOccupancyGrid(
    const std::string& name, std::optional<double> resolution) {
  return maps_->GetMapGrid(
      name, resolution,
      [&](const std::string& session_id) {
        return queries_->GetOccupancyGrid(session_id, resolution);
      },
      SessionNodesForMaps(*queries_));
}

absl::StatusOr<v1::MapSegmentMap> SlamRegistry::GetMapSegments(const std::string& name) {
  return maps_->GetMapSegments(
      name, [&](const std::string& session_id) { return queries_->GetMap(session_id); },
      SessionNodesForMaps(*queries_));
}

void SlamRegistry::SetUpdateObserver(UpdateObserver observer) {
  streams_->SetUpdateObserver(std::move(observer));
}

uint64_t SlamRegistry::AddObserver(SlamObserver observer) {
  return streams_->AddObserver(std::move(observer));
}

void SlamRegistry::RemoveObserver(uint64_t id) { streams_->RemoveObserver(id); }

absl::Status SlamRegistry::CheckpointAll() { return persistence_->CheckpointAll(*table_); }

absl::Status SlamRegistry::Shutdown() {
  std::lock_guard<std::mutex> shutdown_lock(shutdown_mutex_);
  if (shut_down_) return absl::OkStatus();
  shut_down_ = true;
  shutting_down_ = true;  // Submit and OpenStream refuse from now on
  if (tie_worker_ != nullptr) tie_worker_->Stop();  // it reads the sessions stopped below
  maps_->ReleaseLeases();  // another server may tie and follow them at once
  const std::vector<std::shared_ptr<SlamSession>> sessions = table_->All();
  // The workers still run: let every accepted message be processed (and answered) first.
  for (const std::shared_ptr<SlamSession>& session : sessions) WaitIdle(*session);
  scheduler_->StopTimers();
  absl::Status status = CheckpointAll();
  // Saved: another server may take the sessions over at once instead of waiting for expiry.
  for (const std::shared_ptr<SlamSession>& session : sessions) leases_.Release(session->id);
  scheduler_->StopWorkers();
  if (journal_ != nullptr) {
    journal_->Stop();
    const SlamJournalStats stats = journal_->stats();
    spdlog::info("SLAM journal: {} messages ({:.1f} MB) in {} transactions, {:.2f} ms each on "
                 "average, {} failed",
                 stats.messages, stats.bytes / 1e6, stats.batches,
                 stats.batches > 0 ? stats.write_ms / static_cast<double>(stats.batches) : 0.0,
                 stats.failed_batches);
  }
  spdlog::info("SLAM: stopped; {} sessions in memory were saved", sessions.size());
  return status;
}

}  // namespace waymark::service

#include "server/service/slam/session_lifecycle.h"

#include <spdlog/spdlog.h>

#include <cinttypes>
#include <cstdio>
#include <random>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/service/slam/laser_session_engine.h"
#include "server/service/slam/session_persistence.h"
#include "server/service/slam/session_queries.h"
#include "server/service/slam/session_table.h"
#include "server/service/slam/slam_params.h"
#include "server/service/slam/visual_params.h"
#include "server/service/slam/visual_session_engine.h"

namespace waymark::service {

namespace {

std::string NewSessionId() {
  std::random_device device;
  uint64_t words[2];
  for (uint64_t& word : words) {
    word = (static_cast<uint64_t>(device()) << 32) ^ static_cast<uint64_t>(device());
  }
  char text[33];
  std::snprintf(text, sizeof(text), "%016" PRIx64 "%016" PRIx64, words[0], words[1]);
  return text;
}

}  // namespace

absl::Status SessionLifecycle::CheckNewSessionRequest(const std::string& robot_id,
                                                      const std::string& name) {
  if (robot_id.empty()) {
    return absl::InvalidArgumentError("robot_id is empty: name the robot that owns the session");
  }
  if (robot_id.size() > kMaxRobotIdLength) {
    return absl::InvalidArgumentError(absl::StrCat("robot_id is ", robot_id.size(),
                                                   " bytes long; at most ", kMaxRobotIdLength));
  }
  if (name.size() > kMaxSessionNameLength) {
    return absl::InvalidArgumentError(absl::StrCat("name is ", name.size(),
                                                   " bytes long; at most ", kMaxSessionNameLength));
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Creation

absl::StatusOr<v1::Session> SessionLifecycle::CreateSession(
    const v1::CreateSessionRequest& request) {
  if (*shutting_down_) return absl::UnavailableError("the server is shutting down");
  if (absl::Status s = CheckNewSessionRequest(request.robot_id(), request.name()); !s.ok()) {
    return s;
  }
  // Exactly one kind. A request with neither is a laser session with the defaults, as it was
  // before visual sessions existed.
  if (request.has_laser() && request.has_visual()) {
    return absl::InvalidArgumentError(
        "both laser and visual configs are set: a session is either a laser or a visual session");
  }
  const bool visual = request.has_visual();
  std::string config_bytes;
  std::unique_ptr<SessionEngine> engine;
  if (visual) {
    absl::StatusOr<v1::VisualSlamConfig> config = EffectiveVisualConfig(request.visual());
    if (!config.ok()) return config.status();
    // The detector is built here, so a bad model is refused before anything is stored.
    absl::StatusOr<std::unique_ptr<VisualSessionEngine>> built =
        VisualSessionEngine::Create(*config);
    if (!built.ok()) return built.status();
    engine = *std::move(built);
    config_bytes = config->SerializeAsString();
  } else {
    absl::StatusOr<v1::LaserSlamConfig> config = EffectiveLaserConfig(request.laser());
    if (!config.ok()) return config.status();
    LaserSessionEngine::MapPoints map;
    if (config->has_localize()) {
      // The map is found (and refused with a precise error) before anything is stored.
      absl::StatusOr<LaserSessionEngine::MapPoints> loaded =
          persistence_->LoadLocalizationMap(config->localize().map_session_id());
      if (!loaded.ok()) return loaded.status();
      map = *std::move(loaded);
    }
    absl::StatusOr<std::unique_ptr<LaserSessionEngine>> built =
        LaserSessionEngine::Create(*config, map);
    if (!built.ok()) return built.status();
    engine = *std::move(built);
    config_bytes = config->SerializeAsString();
  }
  return StoreNewSession(request.robot_id(), request.name(), std::move(config_bytes),
                         std::move(engine), /*close=*/false);
}

absl::StatusOr<v1::Session> SessionLifecycle::ImportMap(const v1::ImportMapRequest& request) {
  if (*shutting_down_) return absl::UnavailableError("the server is shutting down");
  if (absl::Status s = CheckNewSessionRequest(request.robot_id(), request.name()); !s.ok()) {
    return s;
  }
  absl::StatusOr<laser_slam::OccupancyGrid> grid = FromProtoGrid(request.grid());
  if (!grid.ok()) return grid.status();
  absl::StatusOr<v1::LaserSlamConfig> config = EffectiveLaserConfig(v1::LaserSlamConfig());
  if (!config.ok()) return config.status();
  absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
      LaserSessionEngine::FromImportedGrid(*config, *std::move(grid));
  if (!engine.ok()) return engine.status();
  return StoreNewSession(request.robot_id(), request.name(), config->SerializeAsString(),
                         *std::move(engine), /*close=*/true);
}

absl::StatusOr<v1::Session> SessionLifecycle::StoreNewSession(const std::string& robot_id,
                                                              const std::string& name,
                                                              std::string config_bytes,
                                                              std::unique_ptr<SessionEngine> engine,
                                                              bool close) {
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (!close) {
    // With leases the database holds every server's sessions: count this server's own.
    absl::StatusOr<int64_t> open = store_->CountSessions(storage::SlamSessionState::kOpen);
    if (leases_->enabled()) open = static_cast<int64_t>(table_->size());
    if (!open.ok()) return open.status();
    if (*open >= options_.max_sessions) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "this server holds ", *open, " open SLAM sessions, its limit (--max-sessions ",
          options_.max_sessions, "); close finished sessions with CloseSession"));
    }
  }
  storage::SlamSessionRecord record;
  record.robot_id = robot_id;
  record.name = name;
  record.kind = engine->kind();
  record.config = std::move(config_bytes);
  absl::StatusOr<storage::SlamSessionRecord> created;
  for (int attempt = 0; attempt < 3; ++attempt) {  // a 128-bit collision is not expected
    record.id = NewSessionId();
    created = store_->CreateSession(record);
    if (!absl::IsAlreadyExists(created.status())) break;
  }
  if (!created.ok()) return created.status();
  if (!close) {
    if (absl::Status s = leases_->Take(created->id); !s.ok()) {
      (void)store_->DeleteSession(created->id);
      return s;
    }
  }
  if (close) {
    // Stored closed at once, with the engine's state as its only checkpoint.
    storage::SlamCheckpoint checkpoint;
    checkpoint.state = engine->SerializeState();
    if (absl::Status s = store_->CloseSession(created->id, checkpoint); !s.ok()) {
      (void)store_->DeleteSession(created->id);
      return s;
    }
    absl::StatusOr<storage::SlamSessionRecord> stored = store_->GetSession(created->id);
    if (!stored.ok()) return stored.status();
    return DescribeSession(*stored, nullptr);
  }

  std::shared_ptr<SlamSession> session = persistence_->memory().NewSession(created->id);
  session->robot_id = created->robot_id;
  session->name = created->name;
  session->kind = created->kind;
  session->created_at = created->created_at;
  session->updated_at = created->updated_at;
  session->engine = std::move(engine);
  table_->Put(session);
  v1::Session described = DescribeSession(*created, session.get());
  // This server holds the new session's lease: a fleet client opens its stream here at once.
  if (leases_->enabled()) described.set_served_by(leases_->address());
  return described;
}

// ---------------------------------------------------------------------------------------------
// Residence

absl::StatusOr<std::shared_ptr<SlamSession>> SessionLifecycle::ResidentOrLoad(
    const std::string& id, bool* loaded) {
  if (loaded != nullptr) *loaded = false;
  if (auto resident = table_->Find(id); resident.ok()) return resident;
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (auto resident = table_->Find(id); resident.ok()) return resident;  // loaded meanwhile
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(id);
  if (!record.ok()) return record.status();
  if (record->state == storage::SlamSessionState::kClosed) return SessionClosedError(id);
  // Served by one server at a time: the one that holds the lease.
  if (absl::Status s = leases_->Take(id); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<SlamSession>> session = persistence_->LoadSession(*record);
  if (!session.ok()) return session.status();
  spdlog::info("SLAM session {} resumed from its checkpoint and journal ({} scans, {} poses)", id,
               (*session)->scans_processed, (*session)->engine->trajectory_size());
  if (loaded != nullptr) *loaded = true;
  table_->Put(*session);
  return *session;
}

void SessionLifecycle::RenewLeases() {
  for (auto& [id, moved] : leases_->Renew(table_->Ids())) {
    spdlog::warn("{}", std::string(moved.message()));
    DropLost(id, moved);
  }
}

void SessionLifecycle::DropLost(const std::string& session_id, const absl::Status& moved) {
  std::shared_ptr<SlamSession> session = table_->Take(session_id);
  if (session == nullptr) return;
  {
    std::lock_guard<std::mutex> lock(session->checkpoint_mu);
    session->finalized = true;  // never written again from here: the new holder writes it
  }
  std::lock_guard<std::mutex> lock(session->mu);
  session->lost = moved;
  session->closed = true;
}

// ---------------------------------------------------------------------------------------------
// Closing and deleting

absl::StatusOr<v1::Session> SessionLifecycle::CloseSession(const std::string& session_id) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (absl::Status s = CloseLocked(session_id); !s.ok()) return s;
  absl::StatusOr<storage::SlamSessionRecord> closed = store_->GetSession(session_id);
  if (!closed.ok()) return closed.status();
  return DescribeSession(*closed, nullptr);
}

absl::StatusOr<v1::DeleteSessionResponse> SessionLifecycle::DeleteSession(
    const std::string& session_id, bool force) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  // Held throughout: no stream can load or attach to the session between the close and the delete.
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  v1::DeleteSessionResponse response;
  if (record->state == storage::SlamSessionState::kOpen) {
    if (!force) {
      return absl::FailedPreconditionError(absl::StrCat(
          "SLAM session ", QuotedId(session_id), " is open (", record->scans_processed,
          " scans at its last checkpoint): close it first (CloseSession), or delete it with "
          "force, which closes it and then deletes it"));
    }
    if (absl::Status s = CloseLocked(session_id); !s.ok()) return s;
    response.set_closed_first(true);
  }
  absl::StatusOr<storage::SlamSessionRecord> deleted = store_->DeleteSession(session_id);
  if (!deleted.ok()) return deleted.status();
  *response.mutable_session() = DescribeSession(*deleted, nullptr);
  response.set_trajectory_poses(static_cast<uint64_t>(deleted->trajectory_length));
  spdlog::info("SLAM session {} deleted ({} scans, {} trajectory poses{})", session_id,
               deleted->scans_processed, deleted->trajectory_length,
               response.closed_first() ? ", closed first" : "");
  return response;
}

absl::Status SessionLifecycle::CloseLocked(const std::string& session_id) {
  absl::StatusOr<std::shared_ptr<SlamSession>> resident = table_->Find(session_id);
  if (resident.ok()) {
    SlamSession& session = **resident;
    {
      std::lock_guard<std::mutex> lock(session.mu);
      if (session.stream_attached) {
        return absl::FailedPreconditionError(
            absl::StrCat("SLAM session ", QuotedId(session_id),
                         " has an open stream: half-close it (WritesDone) and wait for its "
                         "answers, then close the session"));
      }
      session.closed = true;
    }
    WaitIdle(session);
    {
      // The back end's last optimisation, so that the closed session keeps its final map.
      std::lock_guard<std::mutex> lock(session.engine_mu);
      session.engine->Finish();
    }
    if (absl::Status s = persistence_->Checkpoint(session, /*close=*/true); !s.ok()) {
      std::lock_guard<std::mutex> lock(session.mu);
      session.closed = false;
      return s;
    }
    table_->Erase(session_id);
  } else {
    absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
    if (!record.ok()) return record.status();
    if (record->state == storage::SlamSessionState::kClosed) {
      return absl::FailedPreconditionError(
          absl::StrCat("SLAM session ", QuotedId(session_id), " is already closed"));
    }
    // Not in memory (a server that stopped without a final checkpoint): its last checkpoint and
    // its journal are its final state, if no other server serves it.
    if (absl::Status s = leases_->Take(session_id); !s.ok()) return s;
    if (absl::StatusOr<std::shared_ptr<SlamSession>> loaded = persistence_->LoadSession(*record);
        loaded.ok()) {
      (*loaded)->engine->Finish();
      return persistence_->Checkpoint(**loaded, /*close=*/true);
    } else {
      spdlog::warn("SLAM session {}: closing at its last checkpoint without its journal: {}",
                   session_id, loaded.status().ToString());
    }
    storage::SlamCheckpoint checkpoint;
    checkpoint.lease_owner = leases_->owner();
    checkpoint.state = record->checkpoint;
    checkpoint.scans_processed = record->scans_processed;
    checkpoint.map_revision = record->map_revision;
    checkpoint.segments = record->segments;
    checkpoint.last_scan_stamp = record->last_scan_stamp;
    checkpoint.last_odometry_stamp = record->last_odometry_stamp;
    checkpoint.journal_through = record->journal_through;
    if (absl::Status s = store_->CloseSession(session_id, checkpoint); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace waymark::service

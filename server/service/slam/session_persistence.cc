#include "server/service/slam/session_persistence.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/service/slam/laser_session_engine.h"
#include "server/service/slam/map_self_check.h"
#include "server/service/slam/session_table.h"
#include "server/service/slam/slam_params.h"
#include "server/service/slam/visual_session_engine.h"

namespace waymark::service {

using ::waymark::MsSince;

namespace {

absl::Status ResumeError(const absl::Status& status) {
  return absl::Status(status.code(),
                      absl::StrCat("cannot resume from its checkpoint: ", status.message()));
}

// Finds the map a localization session localizes on, by the map session's id.
using MapLoader = std::function<absl::StatusOr<LaserSessionEngine::MapPoints>(const std::string&)>;

// Builds the engine of a session from its stored config: new, or resumed from a checkpoint and the
// stored trajectory. Errors say what failed, without the session id.
absl::StatusOr<std::unique_ptr<SessionEngine>> BuildEngine(
    const std::string& kind, const std::string& config_bytes, const std::string* checkpoint,
    std::vector<storage::TrajectoryPoseRecord> trajectory, const MapLoader& load_map) {
  if (kind == "visual") {
    v1::VisualSlamConfig config;
    if (!config.ParseFromString(config_bytes)) {
      return absl::DataLossError("stored config is unreadable");
    }
    if (checkpoint == nullptr) {
      absl::StatusOr<std::unique_ptr<VisualSessionEngine>> engine =
          VisualSessionEngine::Create(config);
      if (!engine.ok()) return engine.status();
      return std::unique_ptr<SessionEngine>(*std::move(engine));
    }
    absl::StatusOr<std::unique_ptr<VisualSessionEngine>> engine =
        VisualSessionEngine::Resume(config, *checkpoint, std::move(trajectory));
    if (!engine.ok()) return ResumeError(engine.status());
    return std::unique_ptr<SessionEngine>(*std::move(engine));
  }
  if (kind != "laser") {
    return absl::DataLossError(absl::StrCat("unknown session kind ", QuotedId(kind)));
  }
  v1::LaserSlamConfig config;
  if (!config.ParseFromString(config_bytes)) {
    return absl::DataLossError("stored config is unreadable");
  }
  if (absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config); !options.ok()) {
    return absl::DataLossError(
        absl::StrCat("stored config is invalid: ", options.status().message()));
  }
  LaserSessionEngine::MapPoints map;
  if (config.has_localize()) {
    absl::StatusOr<LaserSessionEngine::MapPoints> loaded =
        load_map(config.localize().map_session_id());
    if (!loaded.ok()) return loaded.status();
    map = *std::move(loaded);
  }
  if (checkpoint == nullptr) {
    absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
        LaserSessionEngine::Create(config, map);
    if (!engine.ok()) return engine.status();
    return std::unique_ptr<SessionEngine>(*std::move(engine));
  }
  absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
      LaserSessionEngine::FromCheckpoint(config, *checkpoint, trajectory, map);
  if (!engine.ok()) return ResumeError(engine.status());
  return std::unique_ptr<SessionEngine>(*std::move(engine));
}

// The closing session's self-check as stored with its final checkpoint (a serialized
// v1::MapSelfCheck without its cells, which ListSessions shows); empty for a session without
// one. A check that fails is logged, never a reason not to close. Caller holds engine_mu.
std::string FinalMapCheck(SessionEngine& engine, const std::string& session_id) {
  v1::MapSelfCheck check;
  const absl::Status status = engine.CheckMap(&check);
  if (absl::IsFailedPrecondition(status)) return "";
  if (!status.ok()) {
    spdlog::warn("SLAM session {}: the final map's self-check failed: {}", session_id,
                 status.ToString());
    return "";
  }
  if (!check.consistent()) {
    spdlog::warn("SLAM session {}: the final map {}", session_id, check.verdict());
  }
  check.clear_contradicting_cells();
  if (check.worst_areas_size() > static_cast<int>(kMaxSessionCheckAreas)) {
    check.mutable_worst_areas()->DeleteSubrange(
        static_cast<int>(kMaxSessionCheckAreas),
        check.worst_areas_size() - static_cast<int>(kMaxSessionCheckAreas));
  }
  return check.SerializeAsString();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Loading

absl::StatusOr<std::unique_ptr<SessionEngine>> SessionPersistence::EngineOf(
    const storage::SlamSessionRecord& record) {
  std::vector<storage::TrajectoryPoseRecord> trajectory;
  if (!record.checkpoint.empty()) {
    absl::StatusOr<std::vector<storage::TrajectoryPoseRecord>> stored =
        store_->LoadTrajectory(record.id);
    if (!stored.ok()) return stored.status();
    trajectory = *std::move(stored);
  }
  // Created but never checkpointed: nothing was processed that the store knows of.
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = BuildEngine(
      record.kind, record.config, record.checkpoint.empty() ? nullptr : &record.checkpoint,
      std::move(trajectory),
      [this](const std::string& id) { return LoadLocalizationMap(id); });
  if (!engine.ok()) {
    return absl::Status(engine.status().code(), absl::StrCat("SLAM session ", QuotedId(record.id),
                                                             ": ", engine.status().message()));
  }
  return engine;
}

absl::StatusOr<std::shared_ptr<const laser_slam::PointCloud>>
SessionPersistence::LoadLocalizationMap(const std::string& map_session_id) {
  const std::string what = absl::StrCat("map session ", QuotedId(map_session_id));
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(map_session_id);
  if (absl::IsNotFound(record.status())) {
    return absl::NotFoundError(absl::StrCat(
        what, " not found: localize on a closed laser session of this server (ListSessions), or "
              "import a map first (ImportMap, `waymark slam import-map`)"));
  }
  if (!record.ok()) return record.status();
  if (record->kind != "laser") {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is a ", record->kind, " session: it has no laser map to localize on"));
  }
  if (record->state != storage::SlamSessionState::kClosed) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is still open for writing: close it first (CloseSession, `waymark slam close ",
        map_session_id, "`) so that its map is final"));
  }
  v1::LaserSlamConfig config;
  if (config.ParseFromString(record->config) && config.has_localize()) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is itself a localization session: it has no map of its own; localize on ",
        QuotedId(config.localize().map_session_id()), " instead"));
  }
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = EngineOf(*record);
  if (!engine.ok()) return engine.status();
  auto* laser = static_cast<LaserSessionEngine*>(engine->get());
  absl::StatusOr<laser_slam::PointCloud> points = laser->MapPointsForLocalization();
  if (!points.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " cannot be localized on: ", points.status().message()));
  }
  if (points->empty()) {
    return absl::FailedPreconditionError(absl::StrCat(what, " has no scans in its map yet"));
  }
  return std::make_shared<const laser_slam::PointCloud>(*std::move(points));
}

absl::StatusOr<std::shared_ptr<SlamSession>> SessionPersistence::LoadSession(
    const storage::SlamSessionRecord& record) {
  std::shared_ptr<SlamSession> session = memory_.NewSession(record.id);
  session->robot_id = record.robot_id;
  session->name = record.name;
  session->kind = record.kind;
  session->created_at = record.created_at;
  session->updated_at = record.updated_at;
  session->checkpoint_at = record.checkpoint_at;
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = EngineOf(record);
  if (!engine.ok()) return engine.status();
  session->engine = *std::move(engine);
  session->stored_poses = session->engine->trajectory_size();
  session->scans_processed = record.scans_processed;
  session->map_revision = static_cast<uint64_t>(record.map_revision);
  session->segments = record.segments;
  session->processed_scan_stamp = session->accepted_scan_stamp = record.last_scan_stamp;
  session->processed_odometry_stamp = session->accepted_odometry_stamp =
      record.last_odometry_stamp;
  session->journal_last = session->journal_processed = record.journal_through;
  if (record.state == storage::SlamSessionState::kClosed) {
    session->closed = true;
    session->finalized = true;
    return session;
  }
  if (absl::Status s = ReplayJournal(*session); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat("SLAM session ", QuotedId(record.id),
                                               ": cannot replay its journal: ", s.message()));
  }
  return session;
}

absl::Status SessionPersistence::ReplayJournal(SlamSession& session) {
  absl::StatusOr<std::vector<storage::SlamJournalEntry>> journal = store_->LoadJournal(session.id);
  if (!journal.ok()) return journal.status();
  if (journal->empty()) return absl::OkStatus();
  const SessionClock::time_point started = SessionClock::now();
  int replayed = 0;
  // The session is not shared yet: no locks. Each message was admitted and put in time order
  // when it was accepted; what the engine refused then it refuses again (it is deterministic).
  for (storage::SlamJournalEntry& entry : *journal) {
    session.journal_last = entry.seq;
    v1::SensorData data;
    if (!data.ParseFromString(entry.message)) {
      return absl::DataLossError(
          absl::StrCat("journal message ", entry.seq, " is not a waymark.v1.SensorData"));
    }
    absl::StatusOr<AdmittedMessage> admitted = session.engine->Admit(data);
    if (!admitted.ok()) {
      // Only a newer build that admits less could get here; say so and go on without it.
      spdlog::warn("SLAM session {}: journal message {} is no longer admitted: {}", session.id,
                   entry.seq, admitted.status().ToString());
      session.journal_processed = entry.seq;
      continue;
    }
    (admitted->answered ? session.accepted_scan_stamp : session.accepted_odometry_stamp) =
        admitted->stamp;
    (void)ApplyMessage(session, *admitted->input, admitted->answered, admitted->stamp, entry.seq,
                       entry.message.size(), 0.0);
    ++replayed;
  }
  spdlog::info("SLAM session {}: replayed {} journaled messages after its checkpoint in {:.0f} ms",
               session.id, replayed, MsSince(started));
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Checkpoints

absl::Status SessionPersistence::Checkpoint(SlamSession& session, bool close) {
  std::lock_guard<std::mutex> checkpoint_lock(session.checkpoint_mu);
  if (session.finalized) return absl::OkStatus();
  storage::SlamCheckpoint checkpoint;
  int64_t trajectory_size = 0;
  {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    if (!close && !session.dirty) return absl::OkStatus();
    checkpoint.state = session.engine->SerializeState();
    checkpoint.scans_processed = session.scans_processed;
    checkpoint.map_revision = static_cast<int64_t>(session.map_revision);
    checkpoint.segments = session.segments;
    checkpoint.last_scan_stamp = session.processed_scan_stamp;
    checkpoint.last_odometry_stamp = session.processed_odometry_stamp;
    checkpoint.journal_through = session.journal_processed;
    trajectory_size = session.engine->trajectory_size();
    for (int64_t seq = session.stored_poses; seq < trajectory_size; ++seq) {
      checkpoint.new_poses.push_back(session.engine->PoseRecord(seq));
    }
    if (close) checkpoint.map_check = FinalMapCheck(*session.engine, session.id);
    session.dirty = false;
    session.scans_since_checkpoint = 0;
    session.journal_bytes_since_checkpoint = 0;
    session.last_checkpoint = SessionClock::now();
  }
  // Fenced: refused if another server has taken the session over.
  checkpoint.lease_owner = leases_->owner();
  absl::Status status = close ? store_->CloseSession(session.id, checkpoint)
                              : store_->WriteCheckpoint(session.id, checkpoint);
  if (!status.ok()) {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    session.dirty = true;
    return status;
  }
  session.stored_poses = std::max(session.stored_poses, trajectory_size);
  if (close) session.finalized = true;
  std::lock_guard<std::mutex> lock(session.engine_mu);
  session.checkpoint_at = UnixNow();
  return absl::OkStatus();
}

void SessionPersistence::MaybeCheckpoint(SlamSession& session) {
  bool due = false;
  {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    if (!session.dirty) return;
    due = (options_.checkpoint_scans > 0 &&
           session.scans_since_checkpoint >= options_.checkpoint_scans) ||
          (options_.journal &&
           session.journal_bytes_since_checkpoint >= options_.checkpoint_journal_bytes) ||
          (options_.checkpoint_seconds > 0 &&
           std::chrono::duration<double>(SessionClock::now() - session.last_checkpoint).count() >=
               options_.checkpoint_seconds);
  }
  if (!due) return;
  if (absl::Status s = Checkpoint(session, /*close=*/false); !s.ok()) {
    spdlog::warn("SLAM session {}: checkpoint failed (will retry): {}", session.id, s.ToString());
  }
}

void SessionPersistence::CheckpointIdle(const SessionTable& table) {
  for (const std::shared_ptr<SlamSession>& session : table.All()) {
    bool due = false;
    {
      std::lock_guard<std::mutex> engine_lock(session->engine_mu);
      due = session->dirty &&
            std::chrono::duration<double>(SessionClock::now() - session->last_checkpoint)
                    .count() >= options_.checkpoint_seconds;
    }
    if (!due) continue;
    if (absl::Status s = Checkpoint(*session, false); !s.ok()) {
      spdlog::warn("SLAM session {}: checkpoint failed (will retry): {}", session->id,
                   s.ToString());
    }
  }
}

absl::Status SessionPersistence::CheckpointAll(const SessionTable& table) {
  absl::Status first;
  for (const std::shared_ptr<SlamSession>& session : table.All()) {
    absl::Status s = Checkpoint(*session, /*close=*/false);
    if (!s.ok()) {
      spdlog::error("SLAM session {}: checkpoint failed: {}", session->id, s.ToString());
      if (first.ok()) first = s;
    }
  }
  return first;
}

}  // namespace waymark::service

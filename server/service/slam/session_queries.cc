#include "server/service/slam/session_queries.h"

#include <algorithm>
#include <mutex>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/service/slam/session_persistence.h"
#include "server/service/slam/laser_session_engine.h"
#include "server/service/slam/session_table.h"
#include "server/service/slam/slam_params.h"
#include "server/service/slam/visual_params.h"
#include "server/service/slam/visual_session_engine.h"

namespace waymark::service {

namespace {

v1::Session::State ToProtoState(storage::SlamSessionState state) {
  return state == storage::SlamSessionState::kClosed ? v1::Session::CLOSED : v1::Session::OPEN;
}

// The config part of a Session for a session that is not in memory.
void DescribeStoredConfig(const storage::SlamSessionRecord& record, v1::Session* out) {
  out->set_kind(record.kind);
  if (record.kind == "visual") {
    v1::VisualSlamConfig config;
    if (config.ParseFromString(record.config)) *out->mutable_visual() = EchoVisualConfig(config);
  } else if (!out->mutable_laser()->ParseFromString(record.config)) {
    out->clear_laser();
  }
}

}  // namespace

v1::Session DescribeSession(const storage::SlamSessionRecord& record, SlamSession* resident) {
  v1::Session out;
  out.set_session_id(record.id);
  out.set_robot_id(record.robot_id);
  out.set_name(record.name);
  out.set_state(ToProtoState(record.state));
  if (resident != nullptr) {
    resident->engine->DescribeConfig(&out);  // fixed since creation: no lock
  } else {
    DescribeStoredConfig(record, &out);
  }
  out.set_scans_processed(static_cast<uint64_t>(record.scans_processed));
  out.set_segments(static_cast<uint32_t>(std::max(0, record.segments)));
  out.set_map_revision(static_cast<uint64_t>(record.map_revision));
  out.set_last_scan_stamp(record.last_scan_stamp.value_or(0.0));
  out.set_created_at_unix(static_cast<int64_t>(record.created_at));
  out.set_updated_at_unix(static_cast<int64_t>(record.updated_at));
  out.set_checkpoint_at_unix(static_cast<int64_t>(record.checkpoint_at));
  // This server's clock against the database's: close enough to tell a live lease from one long
  // expired, which is what an operator asks.
  if (!record.lease.owner.empty() && record.lease.expires_at > UnixNow()) {
    out.set_served_by(record.lease.address);
  }
  if (!record.map_check.empty() && !out.mutable_self_check()->ParseFromString(record.map_check)) {
    out.clear_self_check();  // written by a newer server in a form this one cannot read
  }
  if (resident != nullptr) {
    out.set_resident(true);
    {
      std::lock_guard<std::mutex> lock(resident->engine_mu);
      out.set_scans_processed(static_cast<uint64_t>(resident->scans_processed));
      out.set_segments(static_cast<uint32_t>(std::max(0, resident->segments)));
      out.set_map_revision(resident->map_revision);
      out.set_last_scan_stamp(resident->processed_scan_stamp.value_or(0.0));
      out.set_updated_at_unix(static_cast<int64_t>(resident->updated_at));
      out.set_checkpoint_at_unix(static_cast<int64_t>(resident->checkpoint_at));
    }
    std::lock_guard<std::mutex> lock(resident->mu);
    out.set_messages_rejected(resident->rejected);
    out.set_messages_dropped(resident->dropped);
    out.set_queued_messages(static_cast<uint32_t>(resident->queue.size()));
  }
  return out;
}

absl::StatusOr<v1::Session> SessionQueries::GetSession(const std::string& session_id) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  absl::StatusOr<std::shared_ptr<SlamSession>> resident = table_->Find(session_id);
  return DescribeSession(*record, resident.ok() ? resident->get() : nullptr);
}

absl::StatusOr<v1::ListSessionsResponse> SessionQueries::ListSessions(
    const std::string& robot_id) {
  absl::StatusOr<std::vector<storage::SlamSessionRecord>> records = store_->ListSessions(robot_id);
  if (!records.ok()) return records.status();
  v1::ListSessionsResponse response;
  for (const storage::SlamSessionRecord& record : *records) {
    absl::StatusOr<std::shared_ptr<SlamSession>> resident = table_->Find(record.id);
    *response.add_sessions() = DescribeSession(record, resident.ok() ? resident->get() : nullptr);
  }
  return response;
}

absl::StatusOr<std::shared_ptr<SlamSession>> SessionQueries::SessionToRead(
    const std::string& session_id, const absl::Status& visual_refusal) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  if (auto resident = table_->Find(session_id); resident.ok()) return *resident;
  // Not in memory (closed, or not resumed since a restart): rebuild the engine from the
  // checkpoint to read it, without making the session resident.
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  if (record->kind == "visual") return visual_refusal;  // without building a detector
  return persistence_->LoadSession(*record);
}

absl::StatusOr<v1::SegmentMap> SessionQueries::GetMap(const std::string& session_id) {
  absl::StatusOr<std::shared_ptr<SlamSession>> session =
      SessionToRead(session_id, NoSegmentMapError());
  if (!session.ok()) return session.status();
  v1::SegmentMap map;
  map.set_session_id(session_id);
  std::lock_guard<std::mutex> lock((*session)->engine_mu);
  map.set_map_revision((*session)->map_revision);
  if (absl::Status s = (*session)->engine->FillMap(&map); !s.ok()) return s;
  // A session without a self-check (no scans kept) answers its map without one.
  if (absl::Status s = (*session)->engine->CheckMap(map.mutable_self_check());
      absl::IsFailedPrecondition(s)) {
    map.clear_self_check();
  } else if (!s.ok()) {
    return absl::Status(s.code(), absl::StrCat("SLAM session ", QuotedId(session_id),
                                               ": the map's self-check: ", s.message()));
  }
  return map;
}

absl::StatusOr<v1::Trajectory> SessionQueries::GetTrajectory(const std::string& session_id) {
  if (absl::Status s = CheckSessionId(session_id); !s.ok()) return s;
  v1::Trajectory out;
  out.set_session_id(session_id);
  if (auto resident = table_->Find(session_id); resident.ok()) {
    std::lock_guard<std::mutex> lock((*resident)->engine_mu);
    (*resident)->engine->AppendTrajectory(&out);
    return out;
  }
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  if (record->kind == "laser") {
    // Stored laser poses are in the EKF's frame; the engine corrects them with its pose graph.
    absl::StatusOr<std::shared_ptr<SlamSession>> loaded = persistence_->LoadSession(*record);
    if (!loaded.ok()) return loaded.status();
    (*loaded)->engine->AppendTrajectory(&out);
    return out;
  }
  absl::StatusOr<std::vector<storage::TrajectoryPoseRecord>> poses =
      store_->LoadTrajectory(session_id);
  if (!poses.ok()) return poses.status();
  for (const storage::TrajectoryPoseRecord& pose : *poses) {
    *out.add_poses() = TrajectoryPoseFromRecord(pose);
  }
  return out;
}

absl::StatusOr<v1::OccupancyGrid> SessionQueries::GetOccupancyGrid(
    const std::string& session_id, std::optional<double> resolution) {
  const double cell = resolution.value_or(0.05);
  if (absl::Status s = InRange(cell, "resolution", 0.01, 1.0, false, "m"); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<SlamSession>> session = SessionToRead(
      session_id, absl::FailedPreconditionError(absl::StrCat(
                      "SLAM session ", QuotedId(session_id),
                      " is a visual session: only laser sessions have an occupancy grid")));
  if (!session.ok()) return session.status();
  v1::OccupancyGrid grid;
  grid.set_session_id(session_id);
  std::lock_guard<std::mutex> lock((*session)->engine_mu);
  grid.set_map_revision((*session)->map_revision);
  if (absl::Status s = (*session)->engine->FillOccupancyGrid(cell, &grid); !s.ok()) {
    return absl::Status(s.code(),
                        absl::StrCat("SLAM session ", QuotedId(session_id), ": ", s.message()));
  }
  return grid;
}

absl::StatusOr<TrajectoryNodes> SessionQueries::TrajectoryNodesOf(const std::string& session_id) {
  absl::StatusOr<std::shared_ptr<SlamSession>> session = SessionToRead(
      session_id, absl::FailedPreconditionError(absl::StrCat(
                      "SLAM session ", QuotedId(session_id), " is a visual session: no nodes")));
  if (!session.ok()) return session.status();
  // The engine is fixed once the session is built; the shared pointer keeps it alive.
  const auto* laser = dynamic_cast<const LaserSessionEngine*>((*session)->engine.get());
  if (laser == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("SLAM session ", QuotedId(session_id), " is not a laser session"));
  }
  TrajectoryNodes out;
  {
    // Before the nodes: a feed never claims scans its nodes do not hold yet.
    std::lock_guard<std::mutex> lock((*session)->engine_mu);
    out.scans_processed = (*session)->scans_processed;
  }
  out.nodes = laser->Nodes();
  out.loops = laser->Loops();
  out.resident = table_->Find(session_id).ok();
  return out;
}

bool SessionQueries::IsResident(const std::string& session_id) const {
  return table_->Find(session_id).ok();
}

}  // namespace waymark::service

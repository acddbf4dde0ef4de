#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_PERSISTENCE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_PERSISTENCE_H_

// A SLAM session between memory and the store: engines built from the stored config, sessions
// loaded from their checkpoint and stored trajectory with the journal after it replayed, and
// checkpoints written (slam_registry.h says when).
//
// A replayed session holds every message the server accepted, as if it had not stopped: the
// engines are deterministic and their checkpoints exact (a laser session resumed with loop
// closure on ends bit-identical to an uninterrupted one). Checkpoints are fenced by the session's
// lease (session_leases.h): a server that lost the lease cannot overwrite its successor's.

#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/session_leases.h"
#include "server/service/slam/session_memory.h"
#include "server/service/slam/slam_registry_options.h"
#include "server/service/slam/slam_session.h"
#include "storage/slam_store.h"

namespace waymark::service {

class SessionTable;

class SessionPersistence {
 public:
  // None is owned; all must outlive this.
  SessionPersistence(storage::SlamStore* store, const SlamRegistryOptions& options,
                     SessionLeases* leases)
      : store_(store), options_(options), leases_(leases) {}

  // A session's engine built from its stored record (not made resident): new, or resumed from its
  // checkpoint and stored trajectory. Errors name the session.
  absl::StatusOr<std::unique_ptr<SessionEngine>> EngineOf(const storage::SlamSessionRecord& record);
  // The points of the map session a localization session localizes on: NOT_FOUND (unknown),
  // FAILED_PRECONDITION (a visual session, still open, a localization session, no scans kept).
  absl::StatusOr<std::shared_ptr<const laser_slam::PointCloud>> LoadLocalizationMap(
      const std::string& map_session_id);
  // Builds a session (engine from the checkpoint + stored trajectory) from its stored record and,
  // when it is open, replays its journal after the checkpoint. Not made resident.
  absl::StatusOr<std::shared_ptr<SlamSession>> LoadSession(
      const storage::SlamSessionRecord& record);
  // The registry's sessions in memory: every session is built through it (LoadSession here,
  // new ones by SessionLifecycle), so that its release is told (session_memory.h).
  SessionMemory& memory() { return memory_; }

  // Writes the session's engine state, counters and the trajectory poses not yet stored (one
  // transaction); `close` stores it closed with the map's self-check, after which it is never
  // written again. A session with no unsaved work is not written unless `close`.
  absl::Status Checkpoint(SlamSession& session, bool close);
  // After a processed scan: checkpoints when checkpoint_scans scans, checkpoint_journal_bytes of
  // journal or checkpoint_seconds have passed since the last one (a failure is logged, retried).
  void MaybeCheckpoint(SlamSession& session);
  // The timer's round: checkpoints the resident sessions with unsaved work whose last checkpoint
  // is checkpoint_seconds old (idle sessions, which MaybeCheckpoint never sees).
  void CheckpointIdle(const SessionTable& table);
  // Checkpoints every resident session with unsaved work; returns the first error.
  absl::Status CheckpointAll(const SessionTable& table);

 private:
  // Replays the journal after the session's checkpoint (LoadSession).
  absl::Status ReplayJournal(SlamSession& session);

  storage::SlamStore* const store_;
  const SlamRegistryOptions& options_;
  SessionLeases* const leases_;
  SessionMemory memory_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_PERSISTENCE_H_

#include "server/service/slam/slam_registry.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/service/slam/session_lifecycle.h"
#include "server/service/slam/session_persistence.h"
#include "server/service/slam/session_queries.h"
#include "server/service/slam/session_scheduler.h"
#include "server/service/slam/session_streams.h"
#include "server/service/slam/session_table.h"
#include "server/service/slam/slam_journal.h"

namespace waymark::service {

absl::StatusOr<std::unique_ptr<SlamRegistry>> SlamRegistry::Create(
    std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options) {
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
  return std::unique_ptr<SlamRegistry>(new SlamRegistry(std::move(store), options));
}

SlamRegistry::SlamRegistry(std::unique_ptr<storage::SlamStore> store,
                           const SlamRegistryOptions& options)
    : options_(options), store_(std::move(store)), leases_(store_.get(), options.lease) {
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
  return lifecycle_->CreateSession(request);
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
  return streams_->Attach(*session, loaded, std::move(sink), std::move(cancel));
}

absl::StatusOr<v1::Session> SlamRegistry::CloseSession(const std::string& session_id) {
  return lifecycle_->CloseSession(session_id);
}

absl::StatusOr<v1::DeleteSessionResponse> SlamRegistry::DeleteSession(
    const std::string& session_id, bool force) {
  return lifecycle_->DeleteSession(session_id, force);
}

absl::StatusOr<v1::Session> SlamRegistry::GetSession(const std::string& session_id) {
  return queries_->GetSession(session_id);
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
  return queries_->ListSessions(robot_id);
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

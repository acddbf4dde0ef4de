#include "server/service/slam/slam_session.h"

#include <chrono>
#include <exception>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"

namespace waymark::service {

absl::StatusOr<std::optional<v1::SlamUpdate>> ApplyMessage(SlamSession& session,
                                                           EngineInput& input, bool is_scan,
                                                           double stamp, int64_t journal_seq,
                                                           size_t journal_bytes, double queue_ms) {
  // Handled either way: a checkpoint after it includes its journal row (an engine error would
  // refuse it again on a replay).
  session.journal_processed = journal_seq;
  session.journal_bytes_since_checkpoint += journal_bytes;
  absl::StatusOr<std::optional<v1::SlamUpdate>> result;
  try {
    result = session.engine->Process(input, queue_ms);
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("the SLAM engine failed on this message: ", e.what()));
  }
  if (!result.ok()) return result.status();
  if (is_scan) {
    ++session.scans_processed;
    ++session.scans_since_checkpoint;
    session.processed_scan_stamp = stamp;
  } else {
    session.processed_odometry_stamp = stamp;
  }
  session.dirty = true;
  session.updated_at = UnixNow();
  if (result->has_value()) {
    v1::SlamUpdate& update = **result;
    update.set_scans_processed(static_cast<uint64_t>(session.scans_processed));
    if (is_scan) {
      session.map_revision = update.map_revision();
      session.segments = static_cast<int>(update.segments());
    }
  }
  return result;
}

void WaitIdle(SlamSession& session) {
  std::unique_lock<std::mutex> lock(session.mu);
  session.idle_cv.wait(lock, [&session] { return session.queue.empty() && !session.in_flight; });
}

double UnixNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string QuotedId(const std::string& id) { return QuoteClientText(id, 128); }

absl::Status SessionNotFound(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("SLAM session ", QuotedId(id), " not found"));
}

absl::Status SessionClosedError(const std::string& id) {
  return absl::FailedPreconditionError(
      absl::StrCat("SLAM session ", QuotedId(id),
                   " is closed; its map and trajectory can still be read (GetMap, GetTrajectory), "
                   "create a new session to go on mapping"));
}

absl::Status CheckSessionId(const std::string& id) {
  if (id.empty()) return absl::InvalidArgumentError("session_id is empty");
  if (id.size() > 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("session_id is ", id.size(), " characters long; ids have 32"));
  }
  return absl::OkStatus();
}

}  // namespace waymark::service

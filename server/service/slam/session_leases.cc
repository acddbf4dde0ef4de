#include "server/service/slam/session_leases.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "storage/store_util.h"

namespace waymark::service {
namespace {

// `status` carrying the holder's address (SessionOwnerAddress reads it back).
absl::Status Naming(absl::Status status, const std::string& address) {
  status.SetPayload(kSessionOwnerPayload, absl::Cord(address));
  return status;
}

absl::Status HeldElsewhere(const std::string& session_id, const storage::SlamLease& lease) {
  return Naming(absl::FailedPreconditionError(absl::StrCat(
                    "SLAM session \"", session_id, "\" is served by another server, at ",
                    lease.address, ": connect there; if that server is gone, its lease expires "
                    "within about ",
                    std::ceil(std::max(0.0, lease.expires_at - storage::NowSeconds())),
                    " s and any server takes the session over")),
                lease.address);
}

}  // namespace

std::optional<std::string> SessionOwnerAddress(const absl::Status& status) {
  absl::optional<absl::Cord> payload = status.GetPayload(kSessionOwnerPayload);
  if (!payload.has_value()) return std::nullopt;
  return std::string(*payload);
}

absl::Status SessionLeases::Take(const std::string& session_id) {
  if (!enabled()) return absl::OkStatus();
  std::string address;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    address = address_;
  }
  absl::StatusOr<storage::SlamLease> lease =
      store_->AcquireLease(session_id, options_.owner, address, options_.ttl_seconds);
  if (!lease.ok()) return lease.status();
  if (lease->owner != options_.owner) return HeldElsewhere(session_id, *lease);
  return absl::OkStatus();
}

std::vector<std::pair<std::string, absl::Status>> SessionLeases::Renew(
    const std::vector<std::string>& session_ids) {
  std::vector<std::pair<std::string, absl::Status>> lost;
  if (!enabled()) return lost;
  for (const std::string& id : session_ids) {
    const absl::Status taken = Take(id);
    if (std::optional<std::string> holder = SessionOwnerAddress(taken); holder.has_value()) {
      lost.emplace_back(id, Naming(absl::UnavailableError(absl::StrCat(
                                       "SLAM session \"", id, "\" was taken over by the server at ",
                                       *holder,
                                       " (this server could not renew its lease in time): "
                                       "reconnect there; the session resumes from its last "
                                       "checkpoint")),
                                   *holder));
    } else if (!taken.ok() && !absl::IsFailedPrecondition(taken)) {
      spdlog::warn("SLAM session {}: renewing its lease failed (kept; retried): {}", id,
                   taken.ToString());
    }
  }
  return lost;
}

void SessionLeases::Release(const std::string& session_id) {
  if (!enabled()) return;
  if (absl::Status s = store_->ReleaseLease(session_id, options_.owner); !s.ok()) {
    spdlog::warn("SLAM session {}: releasing its lease failed (it expires by itself): {}",
                 session_id, s.ToString());
  }
}

}  // namespace waymark::service

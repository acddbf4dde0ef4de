#include "client/lib/session_resume.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::client {

bool SessionIsGone(const absl::Status& status) {
  return status.code() == absl::StatusCode::kNotFound ||
         (status.code() == absl::StatusCode::kFailedPrecondition &&
          absl::StrContains(status.message(), "is closed")) ||
         status.code() == absl::StatusCode::kInvalidArgument ||
         status.code() == absl::StatusCode::kPermissionDenied ||
         status.code() == absl::StatusCode::kUnauthenticated;
}

void AnsweredProgress::Observe(const v1::SlamUpdate& update) {
  // The latest answer counts, even with a lower count: the session went back to a checkpoint.
  if (update.has_rejection() || update.scans_processed() == 0) return;
  scans_processed_ = update.scans_processed();
  last_stamp_ = update.stamp();
}

std::optional<std::string> ResumeWarning(const std::string& session_id,
                                         const AnsweredProgress& seen,
                                         const v1::StreamStart& start, absl::string_view unit,
                                         absl::string_view whose, absl::string_view consequence) {
  if (!seen.any() || start.scans_processed() >= seen.scans_processed()) return std::nullopt;
  const uint64_t scans = seen.scans_processed() - start.scans_processed();
  const double seconds = seen.last_stamp() - start.last_scan_stamp();
  const std::string gap = absl::StrFormat("%d %s / %.1f s", scans, unit, seconds);
  if (start.from_checkpoint()) {
    const char* from = start.checkpoint_at_unix() > 0 ? "a checkpoint "
                                                       : "its creation (never checkpointed), ";
    return absl::StrCat("warning: session ", session_id, " resumed from ", from, gap, " behind ",
                        whose, ": ", consequence);
  }
  return absl::StrCat("warning: session ", session_id, " holds ", gap, " less than ", whose,
                      " had answered: ", consequence);
}

}  // namespace waymark::client

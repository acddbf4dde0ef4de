#ifndef WAYMARK_CLIENT_LIB_SESSION_RESUME_H_
#define WAYMARK_CLIENT_LIB_SESSION_RESUME_H_

// Reopening a stream on the same session after it broke (the robot loop, `vo run`): whether that
// is worth trying, and what the session lost. A server that crashed (or lost its shutdown
// checkpoint) resumes the session from its last checkpoint, and whatever it processed after that
// is gone: the robot that had those answers must be told loudly, since the map and pose restart
// from there (issue 15: a robot at (9.4, 5.2) went on from (0, 0) silently).

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::client {

// A stream ended with `status` cannot be reopened on its session: the session is unknown or
// closed, or the caller may not use it. Anything else (server down or restarting, the old stream
// not yet noticed as dead, a keepalive timeout) is worth another try.
bool SessionIsGone(const absl::Status& status);

// The last processed answer a client had from a session, over all its streams.
class AnsweredProgress {
 public:
  // Records an answer; rejections and the answer to a hello change nothing.
  void Observe(const v1::SlamUpdate& update);
  bool any() const { return scans_processed_ > 0; }
  uint64_t scans_processed() const { return scans_processed_; }
  double last_stamp() const { return last_stamp_; }

 private:
  uint64_t scans_processed_ = 0;  // the session's count in the last processed answer
  double last_stamp_ = 0;         // that answer's stamp
};

// A warning when the session a stream attached to (`start`) holds less than `seen`: "session ID
// resumed from a checkpoint 412 scans / 83.0 s behind this robot's stream: the map restarts from
// there". `unit` names what is counted ("scans", "frames"), `whose` the client's side ("this
// robot's stream") and `consequence` what it means for it. nullopt when nothing was lost.
std::optional<std::string> ResumeWarning(const std::string& session_id,
                                         const AnsweredProgress& seen,
                                         const v1::StreamStart& start, absl::string_view unit,
                                         absl::string_view whose, absl::string_view consequence);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_SESSION_RESUME_H_

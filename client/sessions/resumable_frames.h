#ifndef WAYMARK_CLIENT_SESSIONS_RESUMABLE_FRAMES_H_
#define WAYMARK_CLIENT_SESSIONS_RESUMABLE_FRAMES_H_

// Streams a list of camera frames into a visual session and survives a broken stream, as the robot
// loop does: the stream is reopened on the same session with backoff, and sending resumes from the
// first frame not yet answered (issue 15: `vo run` died on "keepalive watchdog timeout" after 50
// of 140 frames). Each reopened stream starts with a hello, so the client learns what the session
// holds before it sends: frames the server processed on the broken stream but whose answers were
// lost with it are not sent again (their stamps would be refused), and a session that resumed
// from an older checkpoint (server restart) is reported.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/slam_client.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

struct ResumableFramesOptions {
  int window = client::kDefaultFrameWindow;  // frames in flight per stream
  // Give up when no frame has been answered for this long across reopen attempts (the server is
  // gone for good); the last stream's error is returned.
  absl::Duration give_up_after = absl::Seconds(60);
  absl::Duration reconnect_initial = absl::Milliseconds(250);
  absl::Duration reconnect_max = absl::Seconds(5);
  absl::Duration hello_timeout = absl::Seconds(30);
};

struct ResumableFramesStats {
  uint64_t frames_sent = 0;      // sends, resends included
  uint64_t reconnects = 0;       // streams reopened after a break
  uint64_t answers_lost = 0;     // frames the server processed but whose answers a break lost
  int max_outstanding = 0;       // the most frames in flight on any stream
};

// Loads frame `index` (0-based) for sending.
using FrameLoader = std::function<absl::StatusOr<v1::ImageFrame>(size_t index)>;
// Called once per frame, with its answer (a rejection included), on a stream's reader thread.
using FrameAnswer = std::function<void(size_t index, const v1::SlamUpdate& update)>;
// Reports a reopened stream and warnings, on the caller's thread.
using FrameEvent = std::function<void(const std::string& message)>;

// Sends frames 0..count-1 (their stamps, strictly increasing, in `stamps`) into `session_id` and
// returns once every frame is answered or cannot be: OK, the error of a frame that could not be
// loaded, or the last stream's error when the session is gone (closed, unknown) or the server
// stayed away for give_up_after.
absl::Status StreamFramesResumably(client::SlamClient& client, const std::string& session_id,
                                   const std::vector<double>& stamps, const FrameLoader& load,
                                   const FrameAnswer& on_answer, const FrameEvent& on_event,
                                   const ResumableFramesOptions& options,
                                   ResumableFramesStats* stats);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_RESUMABLE_FRAMES_H_

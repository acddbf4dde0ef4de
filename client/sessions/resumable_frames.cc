#include "client/sessions/resumable_frames.h"

#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "client/lib/session_resume.h"

namespace waymark::cli {
namespace {

std::string Text(const absl::Status& status) {
  return status.ToString(absl::StatusToStringMode::kWithNoExtraData);
}

constexpr int kUnavailable = 14;  // google.rpc.Code of a rejection

// What the streams' reader threads and the sending thread share.
struct Answers {
  std::mutex mutex;
  std::vector<bool> answered;  // per frame: its answer (or rejection) arrived
  client::AnsweredProgress progress;
  absl::Time last_answer;
  // The current stream had a frame refused for now (UNAVAILABLE: the server is shutting down):
  // that frame and the ones after it go on the next stream.
  bool refused = false;
  std::string refusal;
};

}  // namespace

absl::Status StreamFramesResumably(client::SlamClient& client, const std::string& session_id,
                                   const std::vector<double>& stamps, const FrameLoader& load,
                                   const FrameAnswer& on_answer, const FrameEvent& on_event,
                                   const ResumableFramesOptions& options,
                                   ResumableFramesStats* stats) {
  Answers answers;
  answers.answered.assign(stamps.size(), false);
  answers.last_answer = absl::Now();
  std::vector<bool> lost(stamps.size(), false);  // processed, answer lost: never sent again
  absl::Duration backoff = options.reconnect_initial;
  bool reopened = false;
  while (true) {
    // Each stream numbers its messages from 1: sequence n carries frame (*sent)[n - 1].
    auto sent = std::make_shared<std::vector<size_t>>();
    std::unique_ptr<client::SensorStream> stream = client.StreamSensorData(
        session_id, options.window, [&answers, sent, &on_answer](const v1::SlamUpdate& update) {
          size_t index = 0;
          {
            std::lock_guard<std::mutex> lock(answers.mutex);
            if (update.sequence() == 0 || update.sequence() > sent->size()) return;
            index = (*sent)[update.sequence() - 1];
            if (answers.answered[index]) return;  // every frame is answered once
            if (update.has_rejection() && update.rejection().code() == kUnavailable) {
              answers.refused = true;  // not an answer: sent again on the next stream
              answers.refusal = update.rejection().message();
              return;
            }
            answers.answered[index] = true;
            answers.progress.Observe(update);
            answers.last_answer = absl::Now();
          }
          on_answer(index, update);
        });
    {
      std::lock_guard<std::mutex> lock(answers.mutex);
      answers.refused = false;
    }
    absl::Status broke;
    const absl::StatusOr<v1::StreamStart> start = stream->Hello(options.hello_timeout);
    if (!start.ok()) {
      broke = start.status();
    } else {
      if (reopened) {
        std::lock_guard<std::mutex> lock(answers.mutex);
        if (std::optional<std::string> warning = client::ResumeWarning(
                session_id, answers.progress, *start, "frames", "this run",
                "trajectory.txt keeps the poses already answered, the session goes on from its "
                "checkpoint")) {
          on_event(*warning);
        }
      }
      uint64_t newly_lost = 0;
      for (size_t i = 0; i < stamps.size(); ++i) {
        {
          std::lock_guard<std::mutex> lock(answers.mutex);
          if (answers.refused) {
            broke = absl::UnavailableError(answers.refusal);
            break;
          }
          if (answers.answered[i]) continue;
        }
        if (lost[i]) continue;
        // Processed on the broken stream: the server would refuse its stamp as not increasing.
        if (start->scans_processed() > 0 && stamps[i] <= start->last_scan_stamp()) {
          lost[i] = true;
          ++newly_lost;
          continue;
        }
        absl::StatusOr<v1::ImageFrame> frame = load(i);
        if (!frame.ok()) {
          stream->Cancel();
          stream->Finish().IgnoreError();
          return frame.status();
        }
        {
          std::lock_guard<std::mutex> lock(answers.mutex);
          sent->push_back(i);
        }
        if (broke = stream->SendFrame(*frame); !broke.ok()) break;
      }
      if (newly_lost > 0) {
        stats->answers_lost += newly_lost;
        on_event(fmt::format(
            "warning: session {} processed {} frames whose answers were lost with the broken "
            "stream: they are not in trajectory.txt",
            session_id, newly_lost));
      }
    }
    // A stream the server ended explains itself in Finish(); a hung one must be cancelled first.
    if (!broke.ok() && broke.code() != absl::StatusCode::kUnavailable) stream->Cancel();
    const absl::Status finished = stream->Finish();
    const client::SensorStream::Stats stream_stats = stream->stats();
    stats->frames_sent += stream_stats.frames_sent;
    stats->max_outstanding = std::max(stats->max_outstanding, stream_stats.max_outstanding);
    if (broke.ok() && finished.ok()) {
      std::lock_guard<std::mutex> lock(answers.mutex);
      if (!answers.refused) return absl::OkStatus();
      broke = absl::UnavailableError(answers.refusal);  // the refused go on the next stream
    }
    if (!finished.ok()) broke = finished;
    if (client::SessionIsGone(broke)) return broke;
    {
      std::lock_guard<std::mutex> lock(answers.mutex);
      if (absl::Now() - answers.last_answer > options.give_up_after) {
        return absl::Status(broke.code(),
                            fmt::format("{} (no frame answered for {}; giving up)",
                                        std::string(broke.message()),
                                        absl::FormatDuration(options.give_up_after)));
      }
    }
    if (stream_stats.updates + stream_stats.frames_rejected > 0) {
      backoff = options.reconnect_initial;  // that stream worked: the break is new
    }
    on_event(fmt::format(
        "stream of session {} broken ({}): reopening it in {:.1f} s, resending from the first "
        "frame not answered",
        session_id, Text(broke), absl::ToDoubleSeconds(backoff)));
    std::this_thread::sleep_for(absl::ToChronoNanoseconds(backoff));
    client.ResetConnectBackoff();  // a restarted server is dialled now, not at gRPC's next try
    backoff = std::min(2 * backoff, options.reconnect_max);
    ++stats->reconnects;
    reopened = true;
  }
}

}  // namespace waymark::cli

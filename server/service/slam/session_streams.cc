#include "server/service/slam/session_streams.h"

#include <spdlog/spdlog.h>

#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/service/runtime/grpc_status.h"
#include "server/service/slam/session_persistence.h"
#include "server/service/slam/session_scheduler.h"
#include "server/service/slam/slam_journal.h"

namespace waymark::service {

using ::waymark::MsSince;

namespace {

v1::SlamUpdate Rejection(uint64_t sequence, const absl::Status& status) {
  v1::SlamUpdate update;
  update.set_sequence(sequence);
  update.mutable_rejection()->set_code(static_cast<int32_t>(status.code()));
  update.mutable_rejection()->set_message(BoundedStatusMessage(status.message()));
  return update;
}

absl::Status OrderError(const char* sensor, double stamp, double previous) {
  return absl::InvalidArgumentError(absl::StrCat(
      sensor, " stamp ", stamp, stamp == previous ? " repeats" : " is before",
      " the previous accepted ", sensor, " stamp ", previous,
      "; each sensor's stamps must strictly increase (message ignored, session unchanged)"));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// SlamStream

SlamStream::~SlamStream() { Close(); }

const std::string& SlamStream::session_id() const { return session_->id; }

absl::Status SlamStream::Submit(const v1::SensorData& data) {
  if (stopped_) return absl::FailedPreconditionError("the stream is closed");
  return streams_->Submit(session_, epoch_, data);
}

void SlamStream::StopAccepting() {
  if (stopped_) return;
  stopped_ = true;
  std::lock_guard<std::mutex> lock(session_->mu);
  if (session_->stream_epoch == epoch_) session_->stream_stopping = true;
  // A stream waiting to take over (OpenStream) may be able to at once: the queue may be idle.
  session_->idle_cv.notify_all();
}

void SlamStream::Close() {
  if (closed_) return;
  StopAccepting();
  closed_ = true;
  WaitIdle(*session_);
  std::lock_guard<std::mutex> lock(session_->mu);
  if (session_->stream_epoch != epoch_) return;  // another stream has taken the session over
  session_->sink = nullptr;
  session_->stream_cancel = nullptr;
  session_->stream_attached = false;
  session_->stream_stopping = false;
  session_->idle_cv.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Ownership and handover

absl::StatusOr<std::unique_ptr<SlamStream>> SessionStreams::Attach(
    const std::shared_ptr<SlamSession>& session, bool loaded, SlamUpdateSink sink,
    std::function<void()> cancel) {
  const std::string& session_id = session->id;
  uint64_t epoch = 0;
  {
    SlamSession& s = *session;
    std::unique_lock<std::mutex> lock(s.mu);
    if (s.closed) return SessionClosedError(session_id);
    if (s.stream_attached && !s.stream_stopping) {
      // The newest stream wins: a robot that reconnects (its Wi-Fi dropped, it restarted, it
      // cancelled its stream) gets its session at once. The old stream's connection may be
      // dead without the server knowing it for a minute (keepalive), and a stream the client
      // has just cancelled may not have noticed yet (the issue 21 campaign's reconnects were
      // refused "already has an open stream"). The old stream accepts nothing more and its call
      // is cancelled; what it accepted is still processed before the new stream attaches. The
      // callback runs under the session's lock, so the old call (which detaches under it) is
      // still there.
      s.stream_stopping = true;
      if (s.stream_cancel) s.stream_cancel();
      s.stream_cancel = nullptr;
      spdlog::info("SLAM session {}: a new stream takes over from the open one", session_id);
    }
    // The previous stream has ended: it hands the session over once the messages it accepted
    // are answered, which this waits for, briefly.
    const auto handed_over = [&s] {
      return s.closed || !s.stream_attached || (s.queue.empty() && !s.in_flight);
    };
    if (!s.idle_cv.wait_for(lock, options_.stream_handover_wait, handed_over)) {
      return absl::UnavailableError(absl::StrCat(
          "SLAM session ", QuotedId(session_id), ": its previous stream has ended but the messages "
          "it sent are still being processed (", s.queue.size(), " queued); try again shortly"));
    }
    if (s.closed) return SessionClosedError(session_id);
    s.stream_attached = true;
    s.stream_stopping = false;
    epoch = ++s.stream_epoch;
    s.sink = std::move(sink);
    s.stream_cancel = std::move(cancel);
  }
  // The previous stream has drained the queue before it detached: this is all the session has.
  v1::StreamStart start;
  start.set_from_checkpoint(loaded);
  {
    std::lock_guard<std::mutex> lock(session->engine_mu);
    start.set_scans_processed(static_cast<uint64_t>(session->scans_processed));
    start.set_last_scan_stamp(session->processed_scan_stamp.value_or(0));
    start.set_checkpoint_at_unix(static_cast<int64_t>(session->checkpoint_at));
  }
  return std::unique_ptr<SlamStream>(new SlamStream(this, session, epoch, std::move(start)));
}

// ---------------------------------------------------------------------------------------------
// Admission

absl::Status SessionStreams::Submit(const std::shared_ptr<SlamSession>& owner, uint64_t epoch,
                                    const v1::SensorData& data) {
  SlamSession& session = *owner;
  auto reject = [&session](absl::Status status, bool dropped = false) {
    std::lock_guard<std::mutex> lock(session.mu);
    ++session.rejected;
    if (dropped) ++session.dropped;
    return status;
  };
  if (!data.session_id().empty() && data.session_id() != session.id) {
    return reject(absl::InvalidArgumentError(
        absl::StrCat("message names session ", QuotedId(data.session_id()),
                     " but this stream is on ", QuotedId(session.id),
                     "; one stream serves one session")));
  }
  // The engine is fixed once the session is built, and Admit reads only its fixed part: no lock.
  absl::StatusOr<AdmittedMessage> admitted = session.engine->Admit(data);
  if (!admitted.ok()) return reject(admitted.status());
  for (const auto& [id, observer] : *Observers()) {
    if (observer->on_input) observer->on_input(session.id, data);
  }
  // Serialized outside the session's lock (a camera frame's bytes); dropped if it is refused.
  std::string journal_bytes;
  if (journal_ != nullptr) journal_bytes = data.SerializeAsString();
  QueuedMessage message;
  message.sequence = data.sequence();
  message.is_scan = admitted->answered;
  message.stamp = admitted->stamp;
  message.bytes = admitted->bytes;
  message.input = std::move(admitted->input);
  const double stamp = message.stamp;

  bool schedule = false;
  {
    std::lock_guard<std::mutex> lock(session.mu);
    absl::Status refused;
    std::optional<double>& last =
        message.is_scan ? session.accepted_scan_stamp : session.accepted_odometry_stamp;
    if (session.lost.has_value()) {
      refused = *session.lost;
    } else if (*shutting_down_) {
      refused = absl::UnavailableError(
          "the server is shutting down; resume the session after it restarts");
    } else if (session.closed || !session.stream_attached) {
      refused = absl::FailedPreconditionError("the session is closed");
    } else if (session.stream_epoch != epoch || session.stream_stopping) {
      // Only a taken-over stream gets here: one that stopped itself refuses in SlamStream::Submit.
      refused = absl::AbortedError(
          "a newer stream took this session over (the robot reconnected); this stream ends");
    } else if (last.has_value() && !(stamp > *last)) {
      refused = OrderError(admitted->sensor, stamp, *last);
    } else if (static_cast<int>(session.queue.size()) >= options_.queue_capacity) {
      ++session.dropped;
      refused = absl::ResourceExhaustedError(absl::StrCat(
          "session queue is full (", options_.queue_capacity,
          " messages waiting; message dropped): keep at most ", options_.queue_capacity,
          " messages outstanding (sent after the last answered scan) and resend this one"));
    } else if (message.bytes > 0 && session.queued_bytes > 0 &&
               session.queued_bytes + message.bytes > options_.max_queued_frame_bytes) {
      // The first frame of an empty queue always fits, whatever its size.
      ++session.dropped;
      refused = absl::ResourceExhaustedError(absl::StrCat(
          "session queue holds ", session.queue.size(), " decoded frames (",
          session.queued_bytes / (1024 * 1024), " MiB; limit ",
          options_.max_queued_frame_bytes / (1024 * 1024),
          " MiB; frame dropped): send fewer frames ahead of the answers and resend this one"));
    }
    if (!refused.ok()) {
      ++session.rejected;
      return refused;
    }
    last = stamp;
    message.accepted = SessionClock::now();
    // Journaled under the session's lock, so that its journal seqs are in acceptance order.
    message.journal_seq = ++session.journal_last;
    if (journal_ != nullptr) {
      message.journal_bytes = journal_bytes.size();
      message.journal_ticket = journal_->Append(
          storage::SlamJournalEntry{session.id, message.journal_seq, std::move(journal_bytes)});
    }
    session.queued_bytes += message.bytes;
    session.queue.push_back(std::move(message));
    if (!session.scheduled) {
      session.scheduled = true;
      schedule = true;
    }
  }
  // The run queue holds a shared_ptr: the session lives until its messages are processed.
  if (schedule) scheduler_->Schedule(owner);
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Answers

void SessionStreams::Process(SlamSession& session, QueuedMessage& message,
                             const SlamUpdateSink& sink) {
  if (options_.before_process) options_.before_process(session.id);
  // Processed (and answered) only once stored: what a client was answered survives a crash.
  absl::Status error =
      journal_ != nullptr ? journal_->WaitStored(message.journal_ticket) : absl::OkStatus();
  const double queue_ms = MsSince(message.accepted);
  std::optional<v1::SlamUpdate> answer;
  if (error.ok()) {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    absl::StatusOr<std::optional<v1::SlamUpdate>> result =
        ApplyMessage(session, *message.input, message.is_scan, message.stamp,
                     message.journal_seq, message.journal_bytes, queue_ms);
    if (result.ok()) {
      answer = *std::move(result);
    } else {
      error = result.status();
    }
  } else {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    session.journal_processed = message.journal_seq;  // never stored: nothing to replay
  }
  if (answer.has_value()) answer->set_sequence(message.sequence);
  if (!error.ok()) {
    {
      std::lock_guard<std::mutex> lock(session.mu);
      ++session.rejected;
    }
    answer = Rejection(message.sequence, error);
  }
  // Observed before it goes out, so a client that has the answer can already scrape it.
  if (answer.has_value() && error.ok()) {
    std::shared_ptr<const SlamUpdateObserver> observer;
    {
      std::lock_guard<std::mutex> lock(observer_mutex_);
      observer = observer_;
    }
    if (observer) (*observer)(session.id, *answer);
    for (const auto& [id, watcher] : *Observers()) {
      if (watcher->on_update) watcher->on_update(session.id, *answer);
    }
  }
  if (answer.has_value() && sink) sink(*answer);
  if (message.is_scan && error.ok()) persistence_->MaybeCheckpoint(session);
}

void SessionStreams::SetUpdateObserver(SlamUpdateObserver observer) {
  std::lock_guard<std::mutex> lock(observer_mutex_);
  observer_ = observer ? std::make_shared<const SlamUpdateObserver>(std::move(observer)) : nullptr;
}

uint64_t SessionStreams::AddObserver(SlamObserver observer) {
  std::lock_guard<std::mutex> lock(observer_mutex_);
  auto list = std::make_shared<ObserverList>(*observers_);
  const uint64_t id = next_observer_id_++;
  if (observer.on_released) persistence_->memory().AddObserver(id, observer.on_released);
  list->emplace_back(id, std::make_shared<const SlamObserver>(std::move(observer)));
  observers_ = std::move(list);
  return id;
}

void SessionStreams::RemoveObserver(uint64_t id) {
  std::lock_guard<std::mutex> lock(observer_mutex_);
  auto list = std::make_shared<ObserverList>();
  for (const auto& entry : *observers_) {
    if (entry.first != id) list->push_back(entry);
  }
  observers_ = std::move(list);
  persistence_->memory().RemoveObserver(id);
}

std::shared_ptr<const SessionStreams::ObserverList> SessionStreams::Observers() {
  std::lock_guard<std::mutex> lock(observer_mutex_);
  return observers_;
}

}  // namespace waymark::service

#ifndef WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_
#define WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_

#include <grpcpp/client_context.h>
#include <grpcpp/support/sync_stream.h>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/lib/status_util.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::client {

using Deadline = std::optional<std::chrono::system_clock::time_point>;

// Sets the deadline on the context, if there is one.
void ApplyDeadline(const Deadline& deadline, grpc::ClientContext* context);
// FAILED_PRECONDITION for a second Finish() on a stream.
absl::Status StreamAlreadyFinished();

// Client side of CrossingService.BulkEnroll. Obtain one from CrossingClient::BulkEnroll().
// Not thread-safe: one thread writes, then finishes.
class BulkEnrollWriter {
 public:
  BulkEnrollWriter(v1::CrossingService::StubInterface* stub, Deadline deadline);
  ~BulkEnrollWriter();
  BulkEnrollWriter(const BulkEnrollWriter&) = delete;
  BulkEnrollWriter& operator=(const BulkEnrollWriter&) = delete;

  // Sends one view. false means the stream is broken (the server rejected a view, the deadline
  // passed, the link dropped); stop writing and call Finish() for the reason.
  bool Write(const v1::EnrollViewRequest& request);
  // Half-closes the stream and waits for the summary, or the error that stopped the stream (views
  // written before the error stay enrolled). Call once.
  absl::StatusOr<v1::BulkEnrollResponse> Finish();
  // Aborts the stream from any thread; Finish() then returns CANCELLED.
  void Cancel();

 private:
  grpc::ClientContext context_;
  v1::BulkEnrollResponse response_;
  std::unique_ptr<grpc::ClientWriterInterface<v1::EnrollViewRequest>> writer_;
  bool finished_ = false;
};

// Client side of a bidirectional stream whose server answers every request with one response, in
// order: CrossingService.StreamRecognize (RecognizeStream) and StreamEnroll (EnrollStream).
// Send()/WritesDone() may run on one thread while Read() runs on another; Finish() comes after
// both are done.
template <typename Request, typename Response>
class BidiStream {
 public:
  using Stream = grpc::ClientReaderWriterInterface<Request, Response>;
  // `open` starts the call on the stream's own context (e.g. a stub's StreamRecognize).
  BidiStream(const std::function<std::unique_ptr<Stream>(grpc::ClientContext*)>& open,
             Deadline deadline) {
    ApplyDeadline(deadline, &context_);
    stream_ = open(&context_);
  }
  ~BidiStream() {
    // A stream abandoned halfway is cancelled, so the destructor does not wait for the server.
    if (!finished_) {
      context_.TryCancel();
      stream_->Finish();
    }
  }
  BidiStream(const BidiStream&) = delete;
  BidiStream& operator=(const BidiStream&) = delete;

  // false means the stream is broken; call Finish() for the reason.
  bool Send(const Request& request) { return !writes_done_ && stream_->Write(request); }
  // Blocks for the next result; false once the server has ended the stream (then call Finish()).
  bool Read(Response* response) { return stream_->Read(response); }
  // Tells the server no more requests will come; keep reading the remaining results.
  bool WritesDone() {
    if (writes_done_) return false;
    writes_done_ = true;
    return stream_->WritesDone();
  }
  // The stream's final status. Call once, after Read() returned false (or after Cancel()).
  absl::Status Finish() {
    if (finished_) return StreamAlreadyFinished();
    finished_ = true;
    return ToAbslStatus(stream_->Finish());
  }
  // Aborts the stream from any thread; pending Read() calls return false.
  void Cancel() { context_.TryCancel(); }

 private:
  grpc::ClientContext context_;
  std::unique_ptr<Stream> stream_;
  bool writes_done_ = false;
  bool finished_ = false;
};

using RecognizeStream = BidiStream<v1::RecognizeRequest, v1::RecognizeResponse>;
// Answers are EnrollViewResponse with `index` set (crossing.proto, StreamEnroll).
using EnrollStream = BidiStream<v1::EnrollViewRequest, v1::EnrollViewResponse>;

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_

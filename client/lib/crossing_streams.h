#ifndef WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_
#define WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_

#include <grpcpp/client_context.h>
#include <grpcpp/support/sync_stream.h>

#include <chrono>
#include <memory>
#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::client {

using Deadline = std::optional<std::chrono::system_clock::time_point>;

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

// Client side of CrossingService.StreamRecognize: the server answers every request with one
// response, in order. Send()/WritesDone() may run on one thread while Read() runs on another;
// Finish() comes after both are done.
class RecognizeStream {
 public:
  RecognizeStream(v1::CrossingService::StubInterface* stub, Deadline deadline);
  ~RecognizeStream();
  RecognizeStream(const RecognizeStream&) = delete;
  RecognizeStream& operator=(const RecognizeStream&) = delete;

  // false means the stream is broken; call Finish() for the reason.
  bool Send(const v1::RecognizeRequest& request);
  // Blocks for the next result; false once the server has ended the stream (then call Finish()).
  bool Read(v1::RecognizeResponse* response);
  // Tells the server no more frames will come; keep reading the remaining results.
  bool WritesDone();
  // The stream's final status. Call once, after Read() returned false (or after Cancel()).
  absl::Status Finish();
  // Aborts the stream from any thread; pending Read() calls return false.
  void Cancel();

 private:
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriterInterface<v1::RecognizeRequest, v1::RecognizeResponse>>
      stream_;
  bool writes_done_ = false;
  bool finished_ = false;
};

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_CROSSING_STREAMS_H_

#include "client/lib/crossing_streams.h"

#include "client/lib/status_util.h"

namespace waymark::client {
namespace {

void ApplyDeadline(const Deadline& deadline, grpc::ClientContext* context) {
  if (deadline.has_value()) context->set_deadline(*deadline);
}

absl::Status AlreadyFinished() {
  return absl::FailedPreconditionError("Finish() was already called on this stream");
}

}  // namespace

BulkEnrollWriter::BulkEnrollWriter(v1::CrossingService::StubInterface* stub, Deadline deadline) {
  ApplyDeadline(deadline, &context_);
  writer_ = stub->BulkEnroll(&context_, &response_);
}

BulkEnrollWriter::~BulkEnrollWriter() {
  // A stream abandoned halfway must not commit a summary the caller never sees; cancelling also
  // lets Finish() return at once instead of waiting for the server.
  if (!finished_) {
    context_.TryCancel();
    writer_->Finish();
  }
}

bool BulkEnrollWriter::Write(const v1::EnrollViewRequest& request) {
  return !finished_ && writer_->Write(request);
}

absl::StatusOr<v1::BulkEnrollResponse> BulkEnrollWriter::Finish() {
  if (finished_) return AlreadyFinished();
  finished_ = true;
  writer_->WritesDone();  // may fail on a broken stream; Finish() reports why
  absl::Status status = ToAbslStatus(writer_->Finish());
  if (!status.ok()) return status;
  return response_;
}

void BulkEnrollWriter::Cancel() { context_.TryCancel(); }

RecognizeStream::RecognizeStream(v1::CrossingService::StubInterface* stub, Deadline deadline) {
  ApplyDeadline(deadline, &context_);
  stream_ = stub->StreamRecognize(&context_);
}

RecognizeStream::~RecognizeStream() {
  if (!finished_) {
    context_.TryCancel();
    stream_->Finish();
  }
}

bool RecognizeStream::Send(const v1::RecognizeRequest& request) {
  return !writes_done_ && stream_->Write(request);
}

bool RecognizeStream::Read(v1::RecognizeResponse* response) { return stream_->Read(response); }

bool RecognizeStream::WritesDone() {
  if (writes_done_) return false;
  writes_done_ = true;
  return stream_->WritesDone();
}

absl::Status RecognizeStream::Finish() {
  if (finished_) return AlreadyFinished();
  finished_ = true;
  return ToAbslStatus(stream_->Finish());
}

void RecognizeStream::Cancel() { context_.TryCancel(); }

}  // namespace waymark::client

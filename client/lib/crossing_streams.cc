#include "client/lib/crossing_streams.h"

#include "client/lib/status_util.h"

namespace waymark::client {

void ApplyDeadline(const Deadline& deadline, grpc::ClientContext* context) {
  if (deadline.has_value()) context->set_deadline(*deadline);
}

absl::Status StreamAlreadyFinished() {
  return absl::FailedPreconditionError("Finish() was already called on this stream");
}

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
  if (finished_) return StreamAlreadyFinished();
  finished_ = true;
  writer_->WritesDone();  // may fail on a broken stream; Finish() reports why
  absl::Status status = ToAbslStatus(writer_->Finish());
  if (!status.ok()) return status;
  return response_;
}

void BulkEnrollWriter::Cancel() { context_.TryCancel(); }

}  // namespace waymark::client

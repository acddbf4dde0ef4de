#include "client/lib/crossing_client.h"

#include <algorithm>
#include <thread>
#include <utility>

#include "client/lib/status_util.h"

namespace waymark::client {

Deadline DeadlineAfter(absl::Duration timeout) {
  if (timeout == absl::InfiniteDuration()) return std::nullopt;
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(
             absl::ToChronoNanoseconds(std::max(timeout, absl::ZeroDuration())));
}

CrossingClient::CrossingClient(std::shared_ptr<grpc::ChannelInterface> channel,
                               CrossingClientOptions options)
    : CrossingClient(v1::CrossingService::NewStub(std::move(channel)), options) {}

CrossingClient::CrossingClient(std::unique_ptr<v1::CrossingService::StubInterface> stub,
                               CrossingClientOptions options)
    : stub_(std::move(stub)), options_(std::move(options)) {}

// One deadline covers all attempts, so --timeout bounds what the user waits, retries included.
template <typename Response, typename Invoke>
absl::StatusOr<Response> CrossingClient::Unary(Idempotency idempotency, Invoke invoke) {
  const Deadline deadline = DeadlineAfter(options_.timeout);
  const int max_attempts =
      idempotency == Idempotency::kRead ? std::max(1, options_.retry.max_attempts) : 1;
  for (int attempt = 1;; ++attempt) {
    grpc::ClientContext context;
    if (deadline.has_value()) context.set_deadline(*deadline);
    Response response;
    absl::Status status = ToAbslStatus(invoke(&context, &response));
    if (status.ok()) return response;
    if (attempt >= max_attempts || !IsRetryable(status)) return status;
    const auto delay = absl::ToChronoNanoseconds(
        Jitter(BackoffDelay(options_.retry, attempt), options_.retry.jitter));
    if (deadline.has_value() && std::chrono::system_clock::now() + delay >= *deadline) {
      return status;  // no time left for another attempt; report the real cause
    }
    std::this_thread::sleep_for(delay);
  }
}

absl::StatusOr<v1::CrossingDatabase> CrossingClient::CreateDatabase(
    const v1::CreateDatabaseRequest& request) {
  return Unary<v1::CrossingDatabase>(Idempotency::kWrite, [&](auto* context, auto* response) {
    return stub_->CreateDatabase(context, request, response);
  });
}

absl::StatusOr<v1::ListDatabasesResponse> CrossingClient::ListDatabases(
    const v1::ListDatabasesRequest& request) {
  return Unary<v1::ListDatabasesResponse>(Idempotency::kRead, [&](auto* context, auto* response) {
    return stub_->ListDatabases(context, request, response);
  });
}

absl::StatusOr<v1::DeleteDatabaseResponse> CrossingClient::DeleteDatabase(
    const v1::DeleteDatabaseRequest& request) {
  return Unary<v1::DeleteDatabaseResponse>(Idempotency::kWrite, [&](auto* context, auto* response) {
    return stub_->DeleteDatabase(context, request, response);
  });
}

absl::StatusOr<v1::DatabaseStats> CrossingClient::GetDatabaseStats(
    const v1::GetDatabaseStatsRequest& request) {
  return Unary<v1::DatabaseStats>(Idempotency::kRead, [&](auto* context, auto* response) {
    return stub_->GetDatabaseStats(context, request, response);
  });
}

absl::StatusOr<v1::Crossing> CrossingClient::AddCrossing(const v1::AddCrossingRequest& request) {
  return Unary<v1::Crossing>(Idempotency::kWrite, [&](auto* context, auto* response) {
    return stub_->AddCrossing(context, request, response);
  });
}

absl::StatusOr<v1::ListCrossingsResponse> CrossingClient::ListCrossings(
    const v1::ListCrossingsRequest& request) {
  return Unary<v1::ListCrossingsResponse>(Idempotency::kRead, [&](auto* context, auto* response) {
    return stub_->ListCrossings(context, request, response);
  });
}

absl::StatusOr<v1::DeleteCrossingResponse> CrossingClient::DeleteCrossing(
    const v1::DeleteCrossingRequest& request) {
  return Unary<v1::DeleteCrossingResponse>(Idempotency::kWrite, [&](auto* context, auto* response) {
    return stub_->DeleteCrossing(context, request, response);
  });
}

absl::StatusOr<v1::EnrollViewResponse> CrossingClient::EnrollView(
    const v1::EnrollViewRequest& request) {
  return Unary<v1::EnrollViewResponse>(Idempotency::kWrite, [&](auto* context, auto* response) {
    return stub_->EnrollView(context, request, response);
  });
}

absl::StatusOr<v1::RebuildClustersResponse> CrossingClient::RebuildClusters(
    const v1::RebuildClustersRequest& request) {
  return Unary<v1::RebuildClustersResponse>(
      Idempotency::kWrite, [&](auto* context, auto* response) {
        return stub_->RebuildClusters(context, request, response);
      });
}

absl::StatusOr<v1::RecognizeResponse> CrossingClient::RecognizeCrossing(
    const v1::RecognizeRequest& request) {
  // Recognition reads the database only, so a retry cannot change what the server stores.
  return Unary<v1::RecognizeResponse>(Idempotency::kRead, [&](auto* context, auto* response) {
    return stub_->RecognizeCrossing(context, request, response);
  });
}

std::unique_ptr<BulkEnrollWriter> CrossingClient::BulkEnroll() {
  return std::make_unique<BulkEnrollWriter>(stub_.get(), DeadlineAfter(options_.stream_timeout));
}

std::unique_ptr<RecognizeStream> CrossingClient::StreamRecognize() {
  return std::make_unique<RecognizeStream>(stub_.get(), DeadlineAfter(options_.stream_timeout));
}

}  // namespace waymark::client

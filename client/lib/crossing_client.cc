#include "client/lib/crossing_client.h"

#include <algorithm>
#include <thread>
#include <utility>

#include "client/lib/status_util.h"
#include "client/lib/unary_call.h"

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

absl::StatusOr<v1::CrossingDatabase> CrossingClient::CreateDatabase(
    const v1::CreateDatabaseRequest& request) {
  return CallUnary<v1::CrossingDatabase>(options_.timeout, options_.retry, Idempotency::kWrite,
                                         [&](auto* context, auto* response) {
                                           return stub_->CreateDatabase(context, request, response);
                                         });
}

absl::StatusOr<v1::ListDatabasesResponse> CrossingClient::ListDatabases(
    const v1::ListDatabasesRequest& request) {
  return CallUnary<v1::ListDatabasesResponse>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->ListDatabases(context, request, response);
      });
}

absl::StatusOr<v1::DeleteDatabaseResponse> CrossingClient::DeleteDatabase(
    const v1::DeleteDatabaseRequest& request) {
  return CallUnary<v1::DeleteDatabaseResponse>(
      options_.timeout, options_.retry, Idempotency::kWrite, [&](auto* context, auto* response) {
        return stub_->DeleteDatabase(context, request, response);
      });
}

absl::StatusOr<v1::DatabaseStats> CrossingClient::GetDatabaseStats(
    const v1::GetDatabaseStatsRequest& request) {
  return CallUnary<v1::DatabaseStats>(options_.timeout, options_.retry, Idempotency::kRead,
                                      [&](auto* context, auto* response) {
                                        return stub_->GetDatabaseStats(context, request, response);
                                      });
}

absl::StatusOr<v1::Crossing> CrossingClient::AddCrossing(const v1::AddCrossingRequest& request) {
  return CallUnary<v1::Crossing>(options_.timeout, options_.retry, Idempotency::kWrite,
                                 [&](auto* context, auto* response) {
                                   return stub_->AddCrossing(context, request, response);
                                 });
}

absl::StatusOr<v1::ListCrossingsResponse> CrossingClient::ListCrossings(
    const v1::ListCrossingsRequest& request) {
  return CallUnary<v1::ListCrossingsResponse>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->ListCrossings(context, request, response);
      });
}

absl::StatusOr<v1::DeleteCrossingResponse> CrossingClient::DeleteCrossing(
    const v1::DeleteCrossingRequest& request) {
  return CallUnary<v1::DeleteCrossingResponse>(
      options_.timeout, options_.retry, Idempotency::kWrite, [&](auto* context, auto* response) {
        return stub_->DeleteCrossing(context, request, response);
      });
}

absl::StatusOr<v1::EnrollViewResponse> CrossingClient::EnrollView(
    const v1::EnrollViewRequest& request) {
  return CallUnary<v1::EnrollViewResponse>(
      options_.timeout, options_.retry, Idempotency::kWrite,
      [&](auto* context, auto* response) { return stub_->EnrollView(context, request, response); });
}

absl::StatusOr<v1::RebuildClustersResponse> CrossingClient::RebuildClusters(
    const v1::RebuildClustersRequest& request) {
  return CallUnary<v1::RebuildClustersResponse>(
      options_.timeout, options_.retry, Idempotency::kWrite, [&](auto* context, auto* response) {
        return stub_->RebuildClusters(context, request, response);
      });
}

absl::StatusOr<v1::RecognizeResponse> CrossingClient::RecognizeCrossing(
    const v1::RecognizeRequest& request) {
  // Recognition reads the database only, so a retry cannot change what the server stores.
  return CallUnary<v1::RecognizeResponse>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->RecognizeCrossing(context, request, response);
      });
}

std::unique_ptr<BulkEnrollWriter> CrossingClient::BulkEnroll() {
  return std::make_unique<BulkEnrollWriter>(stub_.get(), DeadlineAfter(options_.stream_timeout));
}

std::unique_ptr<EnrollStream> CrossingClient::StreamEnroll() {
  return std::make_unique<EnrollStream>(
      [this](grpc::ClientContext* context) { return stub_->StreamEnroll(context); },
      DeadlineAfter(options_.stream_timeout));
}

std::unique_ptr<RecognizeStream> CrossingClient::StreamRecognize() {
  return std::make_unique<RecognizeStream>(
      [this](grpc::ClientContext* context) { return stub_->StreamRecognize(context); },
      DeadlineAfter(options_.stream_timeout));
}

}  // namespace waymark::client

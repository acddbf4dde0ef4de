#ifndef WAYMARK_CLIENT_LIB_CROSSING_CLIENT_H_
#define WAYMARK_CLIENT_LIB_CROSSING_CLIENT_H_

#include <grpcpp/channel.h>

#include <memory>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/crossing_streams.h"
#include "client/lib/retry.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::client {

struct CrossingClientOptions {
  // Deadline of every unary call, retries and backoff included. InfiniteDuration() disables it.
  absl::Duration timeout = absl::Seconds(30);
  // Deadline of a whole BulkEnroll / StreamEnroll / StreamRecognize stream. Streams last as long
  // as the import or the robot's drive, so by default they have none; keepalive still detects a
  // dead link.
  absl::Duration stream_timeout = absl::InfiniteDuration();
  // Applied to ListDatabases, GetDatabaseStats, ListCrossings and RecognizeCrossing only.
  RetryOptions retry;
};

// Typed, blocking access to waymark.v1.CrossingService: one method per RPC, errors as absl::Status
// with the server's code and message. Thread-safe (gRPC stubs are); streams are per caller.
class CrossingClient {
 public:
  explicit CrossingClient(std::shared_ptr<grpc::ChannelInterface> channel,
                          CrossingClientOptions options = {});
  // For tests and for callers that wrap the stub (e.g. with interceptors).
  explicit CrossingClient(std::unique_ptr<v1::CrossingService::StubInterface> stub,
                          CrossingClientOptions options = {});

  const CrossingClientOptions& options() const { return options_; }

  absl::StatusOr<v1::CrossingDatabase> CreateDatabase(const v1::CreateDatabaseRequest& request);
  absl::StatusOr<v1::ListDatabasesResponse> ListDatabases(
      const v1::ListDatabasesRequest& request = {});
  absl::StatusOr<v1::DeleteDatabaseResponse> DeleteDatabase(
      const v1::DeleteDatabaseRequest& request);
  absl::StatusOr<v1::DatabaseStats> GetDatabaseStats(const v1::GetDatabaseStatsRequest& request);

  absl::StatusOr<v1::Crossing> AddCrossing(const v1::AddCrossingRequest& request);
  absl::StatusOr<v1::ListCrossingsResponse> ListCrossings(const v1::ListCrossingsRequest& request);
  absl::StatusOr<v1::DeleteCrossingResponse> DeleteCrossing(
      const v1::DeleteCrossingRequest& request);

  absl::StatusOr<v1::EnrollViewResponse> EnrollView(const v1::EnrollViewRequest& request);
  absl::StatusOr<v1::RebuildClustersResponse> RebuildClusters(
      const v1::RebuildClustersRequest& request);

  absl::StatusOr<v1::RecognizeResponse> RecognizeCrossing(const v1::RecognizeRequest& request);

  // Opens a stream; the call starts immediately.
  std::unique_ptr<BulkEnrollWriter> BulkEnroll();
  std::unique_ptr<EnrollStream> StreamEnroll();
  std::unique_ptr<RecognizeStream> StreamRecognize();

 private:
  std::unique_ptr<v1::CrossingService::StubInterface> stub_;
  CrossingClientOptions options_;
};

// The deadline `timeout` from now, or none for an infinite timeout.
Deadline DeadlineAfter(absl::Duration timeout);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_CROSSING_CLIENT_H_

#ifndef WAYMARK_SERVER_SERVICE_CROSSING_SERVICE_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_SERVICE_H_

// waymark.v1.CrossingService: one thin method per RPC (validate, call the registry, translate the
// status). All the work and all the state live in CrossingRegistry.

#include <memory>

#include "server/service/auth/authenticator.h"
#include "server/service/crossing/crossing_registry.h"
#include "server/service/folder.h"
#include "server/service/runtime/idle_stream_reaper.h"
#include "server/service/runtime/parsed_stream.h"
#include "server/service/runtime/stream_limiter.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::service {

class CrossingServiceImpl final : public v1::CrossingService::Service {
 public:
  // Every RPC first checks the caller's token with `auth` (access_policy.h has the table); streams
  // count against the caller's robot in `streams` and end when silent for `idle`'s limit. None is
  // owned.
  // The client streams (BulkEnroll, StreamEnroll, StreamRecognize) are served on raw bytes
  // parsed here (parsed_stream.h): a message that does not parse ends its stream with
  // INVALID_ARGUMENT instead of looking like the stream's end.
  CrossingServiceImpl(CrossingRegistry* registry, Authenticator* auth, StreamLimiter* streams,
                      IdleStreamReaper* idle);

  grpc::Status CreateDatabase(grpc::ServerContext*, const v1::CreateDatabaseRequest* request,
                              v1::CrossingDatabase* response) override;
  grpc::Status ListDatabases(grpc::ServerContext*, const v1::ListDatabasesRequest* request,
                             v1::ListDatabasesResponse* response) override;
  grpc::Status DeleteDatabase(grpc::ServerContext*, const v1::DeleteDatabaseRequest* request,
                              v1::DeleteDatabaseResponse* response) override;
  grpc::Status GetDatabaseStats(grpc::ServerContext*, const v1::GetDatabaseStatsRequest* request,
                                v1::DatabaseStats* response) override;
  grpc::Status AddCrossing(grpc::ServerContext*, const v1::AddCrossingRequest* request,
                           v1::Crossing* response) override;
  grpc::Status ListCrossings(grpc::ServerContext*, const v1::ListCrossingsRequest* request,
                             v1::ListCrossingsResponse* response) override;
  grpc::Status DeleteCrossing(grpc::ServerContext*, const v1::DeleteCrossingRequest* request,
                              v1::DeleteCrossingResponse* response) override;
  grpc::Status EnrollView(grpc::ServerContext*, const v1::EnrollViewRequest* request,
                          v1::EnrollViewResponse* response) override;
  grpc::Status RebuildClusters(grpc::ServerContext*, const v1::RebuildClustersRequest* request,
                               v1::RebuildClustersResponse* response) override;
  grpc::Status RecognizeCrossing(grpc::ServerContext*, const v1::RecognizeRequest* request,
                                 v1::RecognizeResponse* response) override;

  // The client streams, on messages parsed by this server.
  using BulkEnrollStream = ParsedStream<v1::BulkEnrollResponse, v1::EnrollViewRequest>;
  using EnrollStream = ParsedStream<v1::EnrollViewResponse, v1::EnrollViewRequest>;
  using RecognizeStream = ParsedStream<v1::RecognizeResponse, v1::RecognizeRequest>;
  grpc::Status ServeBulkEnroll(grpc::ServerContext* context, BulkEnrollStream* stream);
  grpc::Status ServeStreamEnroll(grpc::ServerContext* context, EnrollStream* stream);
  grpc::Status ServeStreamRecognize(grpc::ServerContext* context, RecognizeStream* stream);

 private:
  // BulkEnroll's views into `response`.
  grpc::Status BulkEnrollInto(grpc::ServerContext* context, BulkEnrollStream* stream,
                              v1::BulkEnrollResponse* response);
  // Authorizes a streaming call and takes a stream slot of the caller's robot (a null lease when
  // auth is off).
  absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> AuthorizeStream(
      const grpc::ServerContext& context, Action action);
  // One view of a BulkEnroll or StreamEnroll stream: the registry's answer, or an INVALID answer
  // for a view rejected as INVALID_ARGUMENT when the request sets skip_invalid. Other errors end
  // the stream (EndEnrollStream says which view and how many were stored before it).
  // `prepared` is the view's PrepareEnrollment, made ahead of the views before it.
  absl::StatusOr<v1::EnrollViewResponse> EnrollStreamedView(
      const v1::EnrollViewRequest& request,
      absl::StatusOr<CrossingRegistry::PreparedEnrollment> prepared, bool* crossing_created);
  static grpc::Status EndEnrollStream(const absl::Status& error,
                                      const v1::EnrollViewRequest& request, int index, int stored);

  CrossingRegistry* registry_;
  Authenticator* auth_;
  StreamLimiter* streams_;
  IdleStreamReaper* idle_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_SERVICE_H_

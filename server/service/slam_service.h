#ifndef WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_

// waymark.v1.SlamService: one thin method per RPC (validate, call the registry, translate the
// status). Sessions, queues, workers and checkpoints live in SlamRegistry.

#include <string>

#include "server/service/auth/authenticator.h"
#include "server/service/folder.h"
#include "server/service/runtime/idle_stream_reaper.h"
#include "server/service/runtime/parsed_stream.h"
#include "server/service/service_call.h"
#include "server/service/slam/slam_registry.h"
#include "server/service/runtime/stream_limiter.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark::service {

// A refusal naming the server that serves the session (session_leases.h) carries its address in
// the trailing metadata too, where a client reads it without parsing the message.
void AddSessionOwnerTrailer(grpc::ServerContext& context, const absl::Status& status);

class SlamServiceImpl final : public v1::SlamService::Service {
 public:
  // Every RPC first checks the caller's token with `auth`; a robot sees and feeds only its own
  // sessions (another robot's: PERMISSION_DENIED); sensor streams count against the session's
  // robot in `streams` and end when silent for `idle`'s limit. None is owned.
  // StreamSensorData is served on raw bytes parsed here (parsed_stream.h): a message that does
  // not parse ends the stream with INVALID_ARGUMENT instead of looking like its end.
  SlamServiceImpl(SlamRegistry* registry, Authenticator* auth, StreamLimiter* streams,
                  IdleStreamReaper* idle);

  grpc::Status CreateSession(grpc::ServerContext*, const v1::CreateSessionRequest* request,
                             v1::Session* response) override;
  // Reads messages and hands them to the registry; a rejected message is answered with a
  // SlamUpdate{sequence, rejection} and the stream goes on. Stream-level errors (no session_id on
  // the first message, unknown or closed session) end the stream with their status. A newer
  // stream on the same session takes it over: this one's call is cancelled at once (what it had
  // accepted is still processed). After the client half-closes, waits until every accepted
  // message has been processed and answered, then returns OK.
  using SensorStream = ParsedStream<v1::SlamUpdate, v1::SensorData>;
  grpc::Status ServeStreamSensorData(grpc::ServerContext* context, SensorStream* stream);
  grpc::Status GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                      v1::SegmentMap* response) override;
  grpc::Status GetTrajectory(grpc::ServerContext*, const v1::GetTrajectoryRequest* request,
                             v1::Trajectory* response) override;
  grpc::Status CloseSession(grpc::ServerContext*, const v1::CloseSessionRequest* request,
                            v1::Session* response) override;
  grpc::Status ListSessions(grpc::ServerContext*, const v1::ListSessionsRequest* request,
                            v1::ListSessionsResponse* response) override;
  // Like CloseSession: the caller's own sessions only (an admin's: any).
  grpc::Status DeleteSession(grpc::ServerContext*, const v1::DeleteSessionRequest* request,
                             v1::DeleteSessionResponse* response) override;
  grpc::Status GetOccupancyGrid(grpc::ServerContext*, const v1::GetOccupancyGridRequest* request,
                                v1::OccupancyGrid* response) override;
  grpc::Status ImportMap(grpc::ServerContext*, const v1::ImportMapRequest* request,
                         v1::Session* response) override;
  // Maps shared by robots: a mapper (or admin) creates and deletes them, anyone with a token
  // reads them (every robot's trajectories in a map are the map's), a robot joins one with
  // CreateSession.
  grpc::Status CreateMap(grpc::ServerContext*, const v1::CreateMapRequest* request,
                         v1::Map* response) override;
  grpc::Status ListMaps(grpc::ServerContext*, const v1::ListMapsRequest* request,
                        v1::ListMapsResponse* response) override;
  grpc::Status GetMapInfo(grpc::ServerContext*, const v1::GetMapInfoRequest* request,
                          v1::Map* response) override;
  grpc::Status DeleteMap(grpc::ServerContext*, const v1::DeleteMapRequest* request,
                         v1::DeleteMapResponse* response) override;
  grpc::Status GetMapOccupancyGrid(grpc::ServerContext*,
                                   const v1::GetMapOccupancyGridRequest* request,
                                   v1::MapOccupancyGrid* response) override;
  grpc::Status GetMapSegments(grpc::ServerContext*, const v1::GetMapSegmentsRequest* request,
                              v1::MapSegmentMap* response) override;

 private:
  // OK when `caller` may use session `session_id`; NOT_FOUND for an unknown session.
  absl::Status CheckSessionOwner(const Caller& caller, const std::string& session_id);

  // The shape of the RPCs that act on one session: authorize, check the session is the caller's,
  // then run `call()` (returning StatusOr<T>).
  // A refusal because another server of the fleet serves the session also names that server in
  // the trailing metadata (AddSessionOwnerTrailer), for the client to go there.
  template <typename T, typename Call>
  grpc::Status ReplyForOwnSession(grpc::ServerContext& context, Action action,
                                  const std::string& session_id, T* response, Call&& call) {
    absl::Status refused;
    grpc::Status status = ReplyAuthorized(*auth_, context, action, response,
                                          [&](const Caller& caller) -> absl::StatusOr<T> {
                                            absl::Status owner =
                                                CheckSessionOwner(caller, session_id);
                                            if (!owner.ok()) return owner;
                                            absl::StatusOr<T> result = call();
                                            if (!result.ok()) refused = result.status();
                                            return result;
                                          });
    AddSessionOwnerTrailer(context, refused);
    return status;
  }

  SlamRegistry* registry_;
  Authenticator* auth_;
  StreamLimiter* streams_;
  IdleStreamReaper* idle_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_

#ifndef WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_

// waymark.v1.SlamService: one thin method per RPC (validate, call the registry, translate the
// status). Sessions, queues, workers and checkpoints live in SlamRegistry.

#include "server/service/slam_registry.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark::service {

class SlamServiceImpl final : public v1::SlamService::Service {
 public:
  explicit SlamServiceImpl(SlamRegistry* registry) : registry_(registry) {}

  grpc::Status CreateSession(grpc::ServerContext*, const v1::CreateSessionRequest* request,
                             v1::Session* response) override;
  // Reads messages and hands them to the registry; a rejected message is answered with a
  // SlamUpdate{sequence, rejection} and the stream goes on. Stream-level errors (no session_id on
  // the first message, unknown or closed session, another stream on the session) end the stream
  // with their status. After the client half-closes, waits until every accepted message has been
  // processed and answered, then returns OK.
  grpc::Status StreamSensorData(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream) override;
  grpc::Status GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                      v1::SegmentMap* response) override;
  grpc::Status GetTrajectory(grpc::ServerContext*, const v1::GetTrajectoryRequest* request,
                             v1::Trajectory* response) override;
  grpc::Status CloseSession(grpc::ServerContext*, const v1::CloseSessionRequest* request,
                            v1::Session* response) override;
  grpc::Status ListSessions(grpc::ServerContext*, const v1::ListSessionsRequest* request,
                            v1::ListSessionsResponse* response) override;

 private:
  SlamRegistry* registry_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SERVICE_H_

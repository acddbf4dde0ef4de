#include "server/service/slam_service.h"

#include <atomic>
#include <memory>
#include <mutex>

#include "server/service/grpc_status.h"

namespace waymark::service {
namespace {

template <typename T>
grpc::Status Reply(absl::StatusOr<T> result, T* response) {
  if (!result.ok()) return ToGrpcStatus(result.status());
  *response = std::move(*result);
  return grpc::Status::OK;
}

// Serializes the writes of one stream: the registry's worker writes answers while the handler
// thread writes rejections (gRPC sync streams allow one Write at a time, concurrent with a Read).
class StreamWriter {
 public:
  explicit StreamWriter(grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream)
      : stream_(stream) {}
  void Write(const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (broken_) return;
    if (!stream_->Write(update)) broken_ = true;  // the client went away; answers are moot
  }

 private:
  grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream_;
  std::mutex mutex_;
  bool broken_ = false;
};

}  // namespace

grpc::Status SlamServiceImpl::CreateSession(grpc::ServerContext*,
                                            const v1::CreateSessionRequest* request,
                                            v1::Session* response) {
  return Reply(registry_->CreateSession(*request), response);
}

grpc::Status SlamServiceImpl::StreamSensorData(
    grpc::ServerContext* context, grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream) {
  v1::SensorData data;
  if (!stream->Read(&data)) return grpc::Status::OK;  // the client sent nothing
  if (data.session_id().empty()) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                        "the first SensorData of a stream must carry session_id (from "
                        "CreateSession or ListSessions)");
  }
  auto writer = std::make_shared<StreamWriter>(stream);
  absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> session = registry_->OpenStream(
      data.session_id(), [writer](const v1::SlamUpdate& update) { writer->Write(update); });
  if (!session.ok()) return ToGrpcStatus(session.status());

  // The first message may carry only the session id (a hello); otherwise it is data like the rest.
  bool have = data.payload_case() != v1::SensorData::PAYLOAD_NOT_SET;
  while (have || stream->Read(&data)) {
    have = false;
    if (context->IsCancelled()) break;
    absl::Status accepted = (*session)->Submit(data);
    if (!accepted.ok()) {
      v1::SlamUpdate rejection;
      rejection.set_sequence(data.sequence());
      rejection.mutable_rejection()->set_code(static_cast<int32_t>(accepted.code()));
      rejection.mutable_rejection()->set_message(std::string(accepted.message()));
      writer->Write(rejection);
    }
  }
  // Half-closed (or cancelled): let the accepted messages be processed and answered.
  (*session)->Close();
  if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
  return grpc::Status::OK;
}

grpc::Status SlamServiceImpl::GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                                     v1::SegmentMap* response) {
  return Reply(registry_->GetMap(request->session_id()), response);
}

grpc::Status SlamServiceImpl::GetTrajectory(grpc::ServerContext*,
                                            const v1::GetTrajectoryRequest* request,
                                            v1::Trajectory* response) {
  return Reply(registry_->GetTrajectory(request->session_id()), response);
}

grpc::Status SlamServiceImpl::CloseSession(grpc::ServerContext*,
                                           const v1::CloseSessionRequest* request,
                                           v1::Session* response) {
  return Reply(registry_->CloseSession(request->session_id()), response);
}

grpc::Status SlamServiceImpl::ListSessions(grpc::ServerContext*,
                                           const v1::ListSessionsRequest* request,
                                           v1::ListSessionsResponse* response) {
  return Reply(registry_->ListSessions(request->robot_id()), response);
}

}  // namespace waymark::service

#include "server/service/slam_service.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>

#include "server/service/runtime/grpc_status.h"
#include "server/service/service_call.h"
#include "server/service/slam/session_leases.h"

namespace waymark::service {
namespace {

// Serializes the writes of one stream: the registry's worker writes answers while the handler
// thread writes rejections (gRPC sync streams allow one Write at a time, concurrent with a Read).
// The first answer, whichever it is, carries the stream's StreamStart.
class StreamWriter {
 public:
  explicit StreamWriter(SlamServiceImpl::SensorStream* stream) : stream_(stream) {}
  // Before the first Write.
  void set_start(const v1::StreamStart& start) {
    std::lock_guard<std::mutex> lock(mutex_);
    start_ = start;
  }
  void Write(const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (broken_) return;
    bool written;
    if (start_.has_value()) {
      v1::SlamUpdate first = update;
      *first.mutable_stream_start() = *start_;
      start_.reset();
      written = stream_->Write(first);
    } else {
      written = stream_->Write(update);
    }
    if (!written) broken_ = true;  // the client went away; answers are moot
  }

 private:
  SlamServiceImpl::SensorStream* stream_;
  std::mutex mutex_;
  std::optional<v1::StreamStart> start_;
  bool broken_ = false;
};

}  // namespace

absl::Status SlamServiceImpl::CheckSessionOwner(const Caller& caller,
                                                const std::string& session_id) {
  // Admins (and auth off) may use every session: no need to look the owner up.
  if (SeesAllRobots(caller)) return absl::OkStatus();
  absl::StatusOr<v1::Session> session = registry_->GetSession(session_id);
  if (!session.ok()) return session.status();
  return CheckRobot(caller, session->robot_id());
}

grpc::Status SlamServiceImpl::CreateSession(grpc::ServerContext* context,
                                            const v1::CreateSessionRequest* request,
                                            v1::Session* response) {
  return ReplyAuthorized(
      *auth_, *context, Action::kSlam, response,
      [&](const Caller& caller) -> absl::StatusOr<v1::Session> {
        if (request->laser().has_localize()) {
          // A map is the session of a robot like any other: a robot localizes on its own maps
          // (an admin may import a map for it: ImportMap with its robot_id).
          absl::Status s = CheckSessionOwner(caller, request->laser().localize().map_session_id());
          if (!s.ok() && !absl::IsNotFound(s)) return s;  // unknown: the registry says it well
        }
        if (request->robot_id().empty() && !caller.auth_off) {
          // A robot's token already says which robot it is.
          v1::CreateSessionRequest own = *request;
          own.set_robot_id(caller.robot_id);
          return registry_->CreateSession(own);
        }
        if (absl::Status s = CheckRobot(caller, request->robot_id()); !s.ok()) return s;
        return registry_->CreateSession(*request);
      });
}

namespace {

grpc::Status WithSessionOwner(grpc::ServerContext& context, const absl::Status& status) {
  AddSessionOwnerTrailer(context, status);
  return ToGrpcStatus(status);
}

}  // namespace

void AddSessionOwnerTrailer(grpc::ServerContext& context, const absl::Status& status) {
  if (std::optional<std::string> owner = SessionOwnerAddress(status); owner.has_value()) {
    context.AddTrailingMetadata(kSessionOwnerMetadata, *owner);
  }
}

SlamServiceImpl::SlamServiceImpl(SlamRegistry* registry, Authenticator* auth,
                                 StreamLimiter* streams, IdleStreamReaper* idle)
    : registry_(registry), auth_(auth), streams_(streams), idle_(idle) {
  MarkMethodStreamed(MethodIndex<v1::SlamService>("StreamSensorData"),
                     ParsedHandler(this, &SlamServiceImpl::ServeStreamSensorData));
}

grpc::Status SlamServiceImpl::ServeStreamSensorData(grpc::ServerContext* context,
                                                    SensorStream* stream) {
  absl::StatusOr<Caller> caller = auth_->Authorize(*context, Action::kSlam);
  if (!caller.ok()) return ToGrpcStatus(caller.status());
  const auto watch =
      idle_->WatchStream(context, IdleStreamReaper::AtShutdown::kEnd, auth_->Revalidation(*context));
  v1::SensorData data;
  if (!stream->Read(&data)) return grpc::Status::OK;  // the client sent nothing
  if (data.session_id().empty()) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                        "the first SensorData of a stream must carry session_id (from "
                        "CreateSession or ListSessions)");
  }
  absl::StatusOr<v1::Session> described = registry_->GetSession(data.session_id());
  if (!described.ok()) return ToGrpcStatus(described.status());
  if (absl::Status s = CheckRobot(*caller, described->robot_id()); !s.ok()) return ToGrpcStatus(s);
  // Counted against the session's robot, so an admin streaming for a robot uses its slots.
  absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> lease =
      streams_->Acquire(described->robot_id());
  if (!lease.ok()) return ToGrpcStatus(lease.status());

  auto writer = std::make_shared<StreamWriter>(stream);
  // A newer stream of the session (the robot reconnected) takes it over and cancels this call.
  absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> session = registry_->OpenStream(
      data.session_id(), [writer](const v1::SlamUpdate& update) { writer->Write(update); },
      [context] { context->TryCancel(); });
  if (!session.ok()) return WithSessionOwner(*context, session.status());
  writer->set_start((*session)->start());

  // The first message may carry only the session id (a hello), answered at once with the
  // stream's start; otherwise it is data like the rest.
  bool have = data.payload_case() != v1::SensorData::PAYLOAD_NOT_SET;
  if (!have) {
    v1::SlamUpdate hello;
    hello.set_sequence(data.sequence());
    writer->Write(hello);
  }
  while (have || stream->Read(&data)) {
    have = false;
    watch->Touch();
    if (context->IsCancelled()) break;
    absl::Status accepted = (*session)->Submit(data);
    if (SessionOwnerAddress(accepted).has_value()) {
      // Another server took the session over: this stream cannot go on; the robot reconnects.
      (*session)->Close();
      return WithSessionOwner(*context, accepted);
    }
    if (absl::IsAborted(accepted)) {
      // A newer stream took the session over (its call is being cancelled too).
      (*session)->Close();
      return ToGrpcStatus(accepted);
    }
    if (!accepted.ok()) {
      v1::SlamUpdate rejection;
      rejection.set_sequence(data.sequence());
      rejection.mutable_rejection()->set_code(static_cast<int32_t>(accepted.code()));
      rejection.mutable_rejection()->set_message(BoundedStatusMessage(accepted.message()));
      writer->Write(rejection);
    }
  }
  // Half-closed (or cancelled): let the accepted messages be processed and answered.
  (*session)->Close();
  if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
  return grpc::Status::OK;
}

grpc::Status SlamServiceImpl::GetMap(grpc::ServerContext* context, const v1::GetMapRequest* request,
                                     v1::SegmentMap* response) {
  return ReplyForOwnSession(*context, Action::kWatchSlam, request->session_id(), response,
                            [&] { return registry_->GetMap(request->session_id()); });
}

grpc::Status SlamServiceImpl::GetTrajectory(grpc::ServerContext* context,
                                            const v1::GetTrajectoryRequest* request,
                                            v1::Trajectory* response) {
  return ReplyForOwnSession(*context, Action::kWatchSlam, request->session_id(), response,
                            [&] { return registry_->GetTrajectory(request->session_id()); });
}

grpc::Status SlamServiceImpl::CloseSession(grpc::ServerContext* context,
                                           const v1::CloseSessionRequest* request,
                                           v1::Session* response) {
  return ReplyForOwnSession(*context, Action::kSlam, request->session_id(), response,
                            [&] { return registry_->CloseSession(request->session_id()); });
}

grpc::Status SlamServiceImpl::DeleteSession(grpc::ServerContext* context,
                                            const v1::DeleteSessionRequest* request,
                                            v1::DeleteSessionResponse* response) {
  return ReplyForOwnSession(*context, Action::kSlam, request->session_id(), response, [&] {
    return registry_->DeleteSession(request->session_id(), request->force());
  });
}

grpc::Status SlamServiceImpl::GetOccupancyGrid(grpc::ServerContext* context,
                                               const v1::GetOccupancyGridRequest* request,
                                               v1::OccupancyGrid* response) {
  return ReplyForOwnSession(*context, Action::kWatchSlam, request->session_id(), response, [&] {
    return registry_->GetOccupancyGrid(
        request->session_id(),
        request->has_resolution() ? std::optional<double>(request->resolution()) : std::nullopt);
  });
}

grpc::Status SlamServiceImpl::ImportMap(grpc::ServerContext* context,
                                        const v1::ImportMapRequest* request,
                                        v1::Session* response) {
  return ReplyAuthorized(
      *auth_, *context, Action::kSlam, response,
      [&](const Caller& caller) -> absl::StatusOr<v1::Session> {
        if (request->robot_id().empty() && !caller.auth_off) {
          v1::ImportMapRequest own = *request;  // a robot's token says which robot it is
          own.set_robot_id(caller.robot_id);
          return registry_->ImportMap(own);
        }
        if (absl::Status s = CheckRobot(caller, request->robot_id()); !s.ok()) return s;
        return registry_->ImportMap(*request);
      });
}

grpc::Status SlamServiceImpl::ListSessions(grpc::ServerContext* context,
                                           const v1::ListSessionsRequest* request,
                                           v1::ListSessionsResponse* response) {
  return ReplyAuthorized(
      *auth_, *context, Action::kWatchSlam, response,
      [&](const Caller& caller) -> absl::StatusOr<v1::ListSessionsResponse> {
        // A robot lists its own sessions; "all robots" means all it may see.
        const std::string robot = request->robot_id().empty() && !SeesAllRobots(caller)
                                      ? caller.robot_id
                                      : request->robot_id();
        if (absl::Status s = CheckRobot(caller, robot); !s.ok()) return s;
        return registry_->ListSessions(robot);
      });
}

grpc::Status SlamServiceImpl::CreateMap(grpc::ServerContext* context,
                                        const v1::CreateMapRequest* request, v1::Map* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditMaps, response,
                         [&](const Caller&) { return registry_->CreateMap(request->name()); });
}

grpc::Status SlamServiceImpl::ListMaps(grpc::ServerContext* context, const v1::ListMapsRequest*,
                                       v1::ListMapsResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadMaps, response,
                         [&](const Caller&) { return registry_->ListMaps(); });
}

grpc::Status SlamServiceImpl::GetMapInfo(grpc::ServerContext* context,
                                         const v1::GetMapInfoRequest* request,
                                         v1::Map* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadMaps, response,
                         [&](const Caller&) {
                           return registry_->GetMapInfo(request->name(), request->node_origins());
                         });
}

grpc::Status SlamServiceImpl::DeleteMap(grpc::ServerContext* context,
                                        const v1::DeleteMapRequest* request,
                                        v1::DeleteMapResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditMaps, response, [&](const Caller&) {
    return registry_->DeleteMap(request->name(), request->force());
  });
}

grpc::Status SlamServiceImpl::GetMapOccupancyGrid(grpc::ServerContext* context,
                                                  const v1::GetMapOccupancyGridRequest* request,
                                                  v1::MapOccupancyGrid* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadMaps, response, [&](const Caller&) {
    return registry_->GetMapOccupancyGrid(
        request->name(),
        request->has_resolution() ? std::optional<double>(request->resolution()) : std::nullopt);
  });
}

grpc::Status SlamServiceImpl::GetMapSegments(grpc::ServerContext* context,
                                             const v1::GetMapSegmentsRequest* request,
                                             v1::MapSegmentMap* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadMaps, response, [&](const Caller&) {
    return registry_->GetMapSegments(request->name());
  });
}

}  // namespace waymark::service

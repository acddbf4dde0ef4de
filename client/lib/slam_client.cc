#include "client/lib/slam_client.h"

#include <algorithm>
#include <utility>

#include "client/lib/crossing_client.h"  // DeadlineAfter
#include "client/lib/status_util.h"
#include "client/lib/unary_call.h"

namespace waymark::client {

constexpr int kResourceExhausted = 8;  // google.rpc.Code
// The trailing metadata a server of a fleet names the session's server in (the server's
// kSessionOwnerMetadata, server/service/slam/session_leases.h).
constexpr char kSessionOwnerKey[] = "waymark-session-owner";

// The server a finished call's refusal names as its session's ("" when none).
std::string SessionOwnerOf(const grpc::ClientContext& context) {
  const auto& trailers = context.GetServerTrailingMetadata();
  auto it = trailers.find(kSessionOwnerKey);
  return it == trailers.end() ? std::string() : std::string(it->second.data(), it->second.size());
}

std::string SessionRoutes::Get(const std::string& session_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = owner_.find(session_id);
  return it == owner_.end() ? std::string() : it->second;
}

void SessionRoutes::Set(const std::string& session_id, const std::string& address) {
  std::lock_guard<std::mutex> lock(mutex_);
  owner_[session_id] = address;
}

void SessionRoutes::Clear(const std::string& session_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  owner_.erase(session_id);
}

SensorStream::SensorStream(v1::SlamService::StubInterface* stub, std::string session_id, int window,
                           Deadline deadline, UpdateCallback on_update,
                           std::shared_ptr<SessionRoutes> routes, std::string via)
    : window_(std::max(1, window)),
      session_id_(std::move(session_id)),
      on_update_(std::move(on_update)),
      routes_(std::move(routes)),
      via_(std::move(via)) {
  if (deadline.has_value()) context_.set_deadline(*deadline);
  stream_ = stub->StreamSensorData(&context_);
  reader_ = std::thread([this] { ReadLoop(); });
}

SensorStream::~SensorStream() {
  if (!finished_) {
    context_.TryCancel();
    if (reader_.joinable()) reader_.join();
    stream_->Finish();
  } else if (reader_.joinable()) {
    reader_.join();
  }
}

void SensorStream::ReadLoop() {
  v1::SlamUpdate update;
  while (stream_->Read(&update)) {
    bool hello_answer = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (update.has_stream_start() && !start_) start_ = update.stream_start();
      // The hello has sequence 0, which no data message has.
      hello_answer = hello_outstanding_ && update.sequence() == 0 && !update.has_rejection();
      if (hello_answer) hello_outstanding_ = false;
    }
    if (hello_answer) {
      changed_.notify_all();
      continue;
    }
    // The callback runs before the answer is counted, so a caller woken by WaitIdle or SendScan
    // already sees what the callback recorded.
    if (on_update_) on_update_(update);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const bool was_scan = outstanding_scans_.erase(update.sequence()) > 0;
      const bool was_frame = was_scan && outstanding_frames_.erase(update.sequence()) > 0;
      const bool was_odometry = !was_scan && odometry_sequences_.erase(update.sequence()) > 0;
      if (update.has_rejection()) {
        if (update.rejection().code() == kResourceExhausted) ++stats_.queue_full;
        if (was_frame) {
          ++stats_.frames_rejected;
        } else if (was_scan) {
          ++stats_.scans_rejected;
        }
        if (was_odometry) ++stats_.odometry_rejected;
      } else if (was_scan) {
        ++stats_.updates;
      }
    }
    changed_.notify_all();
  }
  std::function<void()> on_end;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    read_done_ = true;
    on_end = std::move(on_end_);
  }
  changed_.notify_all();
  if (on_end) on_end();
}

void SensorStream::set_end_callback(std::function<void()> callback) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!read_done_) {
      on_end_ = std::move(callback);
      return;
    }
  }
  if (callback) callback();
}

absl::Status SensorStream::Send(v1::SensorData& message) {
  if (!first_sent_) {
    message.set_session_id(session_id_);
    first_sent_ = true;
  }
  if (!stream_->Write(message)) {
    return absl::UnavailableError("the stream is closed; Finish() reports why");
  }
  return absl::OkStatus();
}

absl::StatusOr<v1::StreamStart> SensorStream::Hello(absl::Duration timeout) {
  if (finished_) return absl::FailedPreconditionError("the stream is finished");
  if (first_sent_) {
    return absl::FailedPreconditionError("a hello must be the stream's first message");
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    hello_outstanding_ = true;
  }
  v1::SensorData hello;  // sequence 0: numbered data starts at 1
  if (absl::Status sent = Send(hello); !sent.ok()) return sent;
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                    [this] { return read_done_ || !hello_outstanding_; });
  if (!hello_outstanding_) {
    if (start_.has_value()) return *start_;
    return absl::UnimplementedError(
        "the server answered the hello without stream_start: it is older than this client");
  }
  if (read_done_) {
    return absl::UnavailableError("the server ended the stream before answering its hello");
  }
  return absl::DeadlineExceededError("no answer to the stream's hello within " +
                                     absl::FormatDuration(timeout));
}

std::optional<v1::StreamStart> SensorStream::start() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return start_;
}

absl::Status SensorStream::SendOdometry(const v1::Odometry& odometry) {
  if (finished_) return absl::FailedPreconditionError("the stream is finished");
  v1::SensorData message;
  *message.mutable_odometry() = odometry;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (read_done_) return absl::UnavailableError("the server ended the stream");
    message.set_sequence(next_sequence_++);
    // Odometry is answered only when rejected; keep the recent sequences to classify those.
    if (odometry_sequences_.size() > 4096) odometry_sequences_.clear();
    odometry_sequences_.insert(message.sequence());
    ++stats_.odometry_sent;
  }
  return Send(message);
}

absl::Status SensorStream::SendScan(const v1::LaserScan& scan) {
  if (finished_) return absl::FailedPreconditionError("the stream is finished");
  v1::SensorData message;
  *message.mutable_scan() = scan;
  return SendWindowed(message, /*is_frame=*/false);
}

absl::Status SensorStream::SendFrame(const v1::ImageFrame& frame) {
  if (finished_) return absl::FailedPreconditionError("the stream is finished");
  v1::SensorData message;
  *message.mutable_frame() = frame;
  return SendWindowed(message, /*is_frame=*/true);
}

absl::Status SensorStream::SendWindowed(v1::SensorData& message, bool is_frame) {
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const bool ready =
        changed_.wait_for(lock, absl::ToChronoNanoseconds(answer_timeout_), [this] {
          return read_done_ || static_cast<int>(outstanding_scans_.size()) < window_;
        });
    if (!ready) {
      return absl::DeadlineExceededError(
          "no answer from the server for " + absl::FormatDuration(answer_timeout_) + " with " +
          std::to_string(outstanding_scans_.size()) + " scans outstanding");
    }
    if (read_done_) return absl::UnavailableError("the server ended the stream");
    message.set_sequence(next_sequence_++);
    outstanding_scans_.insert(message.sequence());
    if (is_frame) {
      outstanding_frames_.insert(message.sequence());
      ++stats_.frames_sent;
    } else {
      ++stats_.scans_sent;
    }
    stats_.max_outstanding =
        std::max(stats_.max_outstanding, static_cast<int>(outstanding_scans_.size()));
  }
  return Send(message);
}

absl::Status SensorStream::Finish() {
  if (finished_) return absl::FailedPreconditionError("Finish() was already called");
  finished_ = true;
  stream_->WritesDone();
  // The server answers every scan before it ends the stream; the reader stops at its end.
  if (reader_.joinable()) reader_.join();
  absl::Status status = ToAbslStatus(stream_->Finish());
  session_owner_ = SessionOwnerOf(context_);
  if (routes_ != nullptr) {
    if (!session_owner_.empty() && session_owner_ != via_) {
      routes_->Set(session_id_, session_owner_);  // the next stream goes there
    } else if (!via_.empty() && !status.ok()) {
      routes_->Clear(session_id_);  // the named server failed us: back to the fleet
    }
  }
  if (status.ok()) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!outstanding_scans_.empty()) {
      return absl::DataLossError("the server ended the stream with " +
                                 std::to_string(outstanding_scans_.size()) + " scans unanswered");
    }
  }
  return status;
}

absl::Status SensorStream::WaitIdle(absl::Duration timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool ready = changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout), [this] {
    return read_done_ || outstanding_scans_.empty();
  });
  if (!outstanding_scans_.empty()) {
    if (read_done_) return absl::UnavailableError("the server ended the stream");
    if (!ready) {
      return absl::DeadlineExceededError("no answer from the server within " +
                                         absl::FormatDuration(timeout) + " with " +
                                         std::to_string(outstanding_scans_.size()) +
                                         " scans outstanding");
    }
  }
  return absl::OkStatus();
}

bool SensorStream::ended() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return read_done_;
}

void SensorStream::Cancel() { context_.TryCancel(); }

int SensorStream::outstanding() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(outstanding_scans_.size());
}

SensorStream::Stats SensorStream::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

SlamClient::SlamClient(std::shared_ptr<grpc::ChannelInterface> channel, SlamClientOptions options)
    : SlamClient(v1::SlamService::NewStub(channel), std::move(options)) {
  channel_ = std::move(channel);
}

bool SlamClient::WaitForConnected(absl::Duration timeout) {
  if (!channel_) return true;
  return channel_->WaitForConnected(absl::ToChronoTime(absl::Now() + timeout));
}

void SlamClient::ResetConnectBackoff() {
  if (auto* channel = dynamic_cast<grpc::Channel*>(channel_.get())) {
    grpc::experimental::ChannelResetConnectionBackoff(channel);
  }
}

SlamClient::SlamClient(std::unique_ptr<v1::SlamService::StubInterface> stub,
                       SlamClientOptions options)
    : stub_(std::move(stub)), options_(std::move(options)) {}

absl::StatusOr<v1::Session> SlamClient::CreateSession(const v1::CreateSessionRequest& request) {
  absl::StatusOr<v1::Session> session =
      CallUnary<v1::Session>(options_.timeout, options_.retry, Idempotency::kWrite,
                             [&](auto* context, auto* response) {
                               return stub_->CreateSession(context, request, response);
                             });
  // In a fleet the server that created the session serves it: its stream goes there, not to
  // whichever server the balancer picks next (which would only redirect it).
  if (session.ok() && options_.connect && !session->served_by().empty()) {
    routes_->Set(session->session_id(), session->served_by());
  }
  return session;
}

absl::StatusOr<v1::SegmentMap> SlamClient::GetMap(const std::string& session_id) {
  v1::GetMapRequest request;
  request.set_session_id(session_id);
  return CallUnary<v1::SegmentMap>(
      options_.timeout, options_.retry, Idempotency::kRead,
      [&](auto* context, auto* response) { return stub_->GetMap(context, request, response); });
}

absl::StatusOr<v1::Trajectory> SlamClient::GetTrajectory(const std::string& session_id) {
  v1::GetTrajectoryRequest request;
  request.set_session_id(session_id);
  return CallUnary<v1::Trajectory>(options_.timeout, options_.retry, Idempotency::kRead,
                                   [&](auto* context, auto* response) {
                                     return stub_->GetTrajectory(context, request, response);
                                   });
}

absl::StatusOr<v1::OccupancyGrid> SlamClient::GetOccupancyGrid(const std::string& session_id,
                                                               std::optional<double> resolution) {
  v1::GetOccupancyGridRequest request;
  request.set_session_id(session_id);
  if (resolution.has_value()) request.set_resolution(*resolution);
  return CallUnary<v1::OccupancyGrid>(options_.timeout, options_.retry, Idempotency::kRead,
                                      [&](auto* context, auto* response) {
                                        return stub_->GetOccupancyGrid(context, request, response);
                                      });
}

absl::StatusOr<v1::Session> SlamClient::ImportMap(const std::string& robot_id,
                                                  const std::string& name,
                                                  const v1::OccupancyGrid& grid) {
  v1::ImportMapRequest request;
  request.set_robot_id(robot_id);
  request.set_name(name);
  *request.mutable_grid() = grid;
  return CallUnary<v1::Session>(
      options_.timeout, options_.retry, Idempotency::kWrite,
      [&](auto* context, auto* response) { return stub_->ImportMap(context, request, response); });
}

absl::StatusOr<v1::Map> SlamClient::CreateMap(const std::string& name) {
  v1::CreateMapRequest request;
  request.set_name(name);
  return CallUnary<v1::Map>(
      options_.timeout, options_.retry, Idempotency::kWrite,
      [&](auto* context, auto* response) { return stub_->CreateMap(context, request, response); });
}

absl::StatusOr<v1::ListMapsResponse> SlamClient::ListMaps() {
  v1::ListMapsRequest request;
  return CallUnary<v1::ListMapsResponse>(
      options_.timeout, options_.retry, Idempotency::kRead,
      [&](auto* context, auto* response) { return stub_->ListMaps(context, request, response); });
}

absl::StatusOr<v1::Map> SlamClient::GetMapInfo(const std::string& name, bool node_origins) {
  v1::GetMapInfoRequest request;
  request.set_name(name);
  request.set_node_origins(node_origins);
  return CallUnary<v1::Map>(
      options_.timeout, options_.retry, Idempotency::kRead,
      [&](auto* context, auto* response) { return stub_->GetMapInfo(context, request, response); });
}

absl::StatusOr<v1::DeleteMapResponse> SlamClient::DeleteMap(const std::string& name, bool force) {
  v1::DeleteMapRequest request;
  request.set_name(name);
  request.set_force(force);
  return CallUnary<v1::DeleteMapResponse>(
      options_.timeout, options_.retry, Idempotency::kWrite,
      [&](auto* context, auto* response) { return stub_->DeleteMap(context, request, response); });
}

absl::StatusOr<v1::MapOccupancyGrid> SlamClient::GetMapOccupancyGrid(
    const std::string& name, std::optional<double> resolution) {
  v1::GetMapOccupancyGridRequest request;
  request.set_name(name);
  if (resolution.has_value()) request.set_resolution(*resolution);
  return CallUnary<v1::MapOccupancyGrid>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->GetMapOccupancyGrid(context, request, response);
      });
}

absl::StatusOr<v1::MapSegmentMap> SlamClient::GetMapSegments(const std::string& name) {
  v1::GetMapSegmentsRequest request;
  request.set_name(name);
  return CallUnary<v1::MapSegmentMap>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->GetMapSegments(context, request, response);
      });
}

template <typename Response, typename Call>
absl::StatusOr<Response> SlamClient::AtSessionServer(const std::string& session_id,
                                                     absl::Duration timeout, Call call) {
  std::string owner;
  const auto on = [&](v1::SlamService::StubInterface* stub) {
    return CallUnary<Response>(timeout, options_.retry, Idempotency::kWrite,
                               [&](grpc::ClientContext* context, Response* response) {
                                 const grpc::Status status = call(stub, context, response);
                                 owner = SessionOwnerOf(*context);
                                 return status;
                               });
  };
  const std::string known = options_.connect ? routes_->Get(session_id) : std::string();
  absl::StatusOr<Response> answer = on(known.empty() ? stub_.get() : StubAt(known));
  if (answer.ok() || owner.empty() || owner == known || !options_.connect ||
      !absl::IsFailedPrecondition(answer.status())) {
    return answer;
  }
  routes_->Set(session_id, owner);
  return on(StubAt(owner));
}

absl::StatusOr<v1::Session> SlamClient::CloseSession(const std::string& session_id) {
  v1::CloseSessionRequest request;
  request.set_session_id(session_id);
  return AtSessionServer<v1::Session>(
      session_id, std::max(options_.timeout, kCloseSessionTimeout),
      [&](v1::SlamService::StubInterface* stub, grpc::ClientContext* context,
          v1::Session* response) { return stub->CloseSession(context, request, response); });
}

absl::StatusOr<v1::DeleteSessionResponse> SlamClient::DeleteSession(const std::string& session_id,
                                                                     bool force) {
  v1::DeleteSessionRequest request;
  request.set_session_id(session_id);
  request.set_force(force);
  return AtSessionServer<v1::DeleteSessionResponse>(
      session_id, options_.timeout,
      [&](v1::SlamService::StubInterface* stub, grpc::ClientContext* context,
          v1::DeleteSessionResponse* response) {
        return stub->DeleteSession(context, request, response);
      });
}

absl::StatusOr<v1::ListSessionsResponse> SlamClient::ListSessions(const std::string& robot_id) {
  v1::ListSessionsRequest request;
  request.set_robot_id(robot_id);
  return CallUnary<v1::ListSessionsResponse>(
      options_.timeout, options_.retry, Idempotency::kRead, [&](auto* context, auto* response) {
        return stub_->ListSessions(context, request, response);
      });
}

v1::SlamService::StubInterface* SlamClient::StubAt(const std::string& address) {
  std::lock_guard<std::mutex> lock(stubs_mutex_);
  std::unique_ptr<v1::SlamService::StubInterface>& stub = stubs_[address];
  if (stub == nullptr) stub = v1::SlamService::NewStub(options_.connect(address));
  return stub.get();
}

std::unique_ptr<SensorStream> SlamClient::StreamSensorData(const std::string& session_id,
                                                           int window,
                                                           SensorStream::UpdateCallback on_update) {
  const std::string owner = options_.connect ? routes_->Get(session_id) : std::string();
  return std::make_unique<SensorStream>(owner.empty() ? stub_.get() : StubAt(owner), session_id,
                                        window, DeadlineAfter(options_.stream_timeout),
                                        std::move(on_update), routes_, owner);
}

}  // namespace waymark::client

#include "server/service/operations/call_interceptor.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <random>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "server/service/auth/call_identity.h"
#include "waymark/v1/crossing.pb.h"

namespace waymark::service {
namespace {

using grpc::experimental::InterceptionHookPoints;
using grpc::experimental::InterceptorBatchMethods;
using grpc::experimental::ServerRpcInfo;

// The RPCs whose answers are RecognizeResponse (crossing.proto), counted by outcome.
constexpr char kRecognizeMethod[] = "/waymark.v1.CrossingService/RecognizeCrossing";
constexpr char kStreamRecognizeMethod[] = "/waymark.v1.CrossingService/StreamRecognize";
constexpr char kHealthPrefix[] = "/grpc.health.v1.Health/";

constexpr size_t kMaxRequestIdLength = 64;
constexpr size_t kMaxLoggedErrorLength = 200;

bool IsIdChar(char c) {
  return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == ':' ||
         c == '-';
}

// A client's id is echoed into our logs and back to it: keep it one short, harmless token.
bool IsPlausibleRequestId(absl::string_view id) {
  if (id.empty() || id.size() > kMaxRequestIdLength) return false;
  for (char c : id) {
    if (!IsIdChar(c)) return false;
  }
  return true;
}

std::string NewRequestId() {
  thread_local std::mt19937_64 random(std::random_device{}());
  return absl::StrFormat("%016x", random());
}

// A value in a key=value log line: "-" when empty, bare when it is one plain token, otherwise
// quoted and C-escaped so spaces, quotes or '=' cannot break the line's structure.
std::string LogValue(absl::string_view value) {
  if (value.empty()) return "-";
  bool plain = true;
  for (char c : value) {
    plain = plain &&
            (IsIdChar(c) || c == '/' || c == '[' || c == ']' || c == '%' || c == '@' || c == '+');
  }
  return plain ? std::string(value) : absl::StrCat("\"", absl::CEscape(value), "\"");
}

class CallInterceptor final : public grpc::experimental::Interceptor {
 public:
  CallInterceptor(ServerRpcInfo* info, Metrics* metrics)
      : context_(info->server_context()),
        method_(info->method() != nullptr ? info->method() : "unknown"),
        streaming_(info->type() != ServerRpcInfo::Type::UNARY),
        single_request_(info->type() == ServerRpcInfo::Type::UNARY ||
                        info->type() == ServerRpcInfo::Type::SERVER_STREAMING),
        metrics_(metrics),
        start_(std::chrono::steady_clock::now()),
        request_id_(NewRequestId()) {
    if (metrics_ != nullptr) {
      if (method_ == kRecognizeMethod || method_ == kStreamRecognizeMethod) {
        recognition_answers_ = true;
      }
      metrics_->RpcStarted(method_);
    }
    // A context address can be reused: a new call starts with no identity (call_identity.h).
    TakeCallRobotId(context_);
  }

  ~CallInterceptor() override {
    // Normally a no-op (the status was seen). If a call is ever freed without sending one, it
    // still leaves the in-flight gauge and gets its counter and log line, as CANCELLED.
    Finish(grpc::Status(grpc::StatusCode::CANCELLED, "call ended without a status"));
    TakeCallRobotId(context_);
  }

  void Intercept(InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      ReadClientMetadata(methods);
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE)) {
      if (methods->GetRecvMessage() != nullptr) {
        received_.fetch_add(1, std::memory_order_relaxed);
      } else if (single_request_) {
        // A unary or server-streaming call's request that did not parse (for a client stream
        // null is the client's end of stream).
        unparsable_request_ = true;
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      if (auto* metadata = methods->GetSendInitialMetadata(); metadata != nullptr) {
        metadata->emplace(kRequestIdKey, request_id_);
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE)) {
      sent_.fetch_add(1, std::memory_order_relaxed);
      // The synchronous API hands the message over unserialized; if another interceptor has
      // serialized it already, the answer is not counted rather than parsed again.
      const void* message = methods->GetSendMessage();
      if (recognition_answers_ && message != nullptr) {
        metrics_->RecordRecognition(*static_cast<const v1::RecognizeResponse*>(message));
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      grpc::Status status = methods->GetSendStatus();
      // gRPC's generated unary handler answers a request that does not parse with INTERNAL, a
      // server fault to the client (130,000 of them in the issue 21 campaign): it is the
      // client's, and says so.
      // gRPC's health service reads its request itself and answers Watch's with INTERNAL "could
      // not parse request" (Check's with INVALID_ARGUMENT).
      const bool health_parse_failure = absl::StartsWith(method_, kHealthPrefix) &&
                                        status.error_message() == "could not parse request";
      if ((unparsable_request_ || health_parse_failure) &&
          status.error_code() == grpc::StatusCode::INTERNAL) {
        status = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                              absl::StrCat("the request to ", method_,
                                           " does not parse as that method's request message"));
        methods->ModifySendStatus(status);
      }
      Finish(status);
    }
    methods->Proceed();
  }

 private:
  // Before the handler runs: nothing else touches request_id_ and peer_ concurrently.
  void ReadClientMetadata(InterceptorBatchMethods* methods) {
    peer_ = context_->peer();
    const auto* metadata = methods->GetRecvInitialMetadata();
    if (metadata == nullptr) return;
    auto it = metadata->find(kRequestIdKey);
    if (it == metadata->end()) return;
    const absl::string_view id(it->second.data(), it->second.size());
    if (IsPlausibleRequestId(id)) request_id_ = std::string(id);
  }

  void Finish(const grpc::Status& sent) {
    if (finished_.exchange(true)) return;
    // A call the client cancelled ends with CANCELLED on the client whatever the handler says:
    // gRPC's health Watch answers a cancelled watch with UNKNOWN "OnCancel()", which would be
    // logged and counted as a server failure every time a load balancer stops watching.
    const grpc::Status status =
        sent.error_code() == grpc::StatusCode::UNKNOWN && context_->IsCancelled()
            ? grpc::Status(grpc::StatusCode::CANCELLED, "cancelled by the client")
            : sent;
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (metrics_ != nullptr) {
      metrics_->RpcFinished(method_, status.error_code(), seconds);
      if (recognition_answers_ && !streaming_ && !status.ok()) metrics_->RecordRecognitionError();
    }
    Log(status, seconds, TakeCallRobotId(context_));
  }

  void Log(const grpc::Status& status, double seconds, const std::string& robot) const {
    std::string line = absl::StrCat(
        "rpc method=", LogValue(method_), " code=", StatusCodeName(status.error_code()),
        " ms=", absl::StrFormat("%.1f", seconds * 1000), " request_id=", request_id_,
        " robot=", LogValue(robot), " peer=", LogValue(peer_));
    if (streaming_) {
      absl::StrAppend(&line, " in=", received_.load(), " out=", sent_.load());
    }
    if (!status.error_message().empty()) {
      const std::string& message = status.error_message();
      absl::StrAppend(&line, " error=\"", absl::CEscape(message.substr(0, kMaxLoggedErrorLength)),
                      message.size() > kMaxLoggedErrorLength ? "..." : "", "\"");
    }
    spdlog::level::level_enum level = spdlog::level::info;
    switch (status.error_code()) {
      case grpc::StatusCode::INTERNAL:
      case grpc::StatusCode::UNKNOWN:
      case grpc::StatusCode::DATA_LOSS:
        level = spdlog::level::warn;
        break;
      case grpc::StatusCode::OK:
      case grpc::StatusCode::CANCELLED:
        if (absl::StartsWith(method_, kHealthPrefix)) level = spdlog::level::debug;
        break;
      default:
        break;
    }
    spdlog::log(level, "{}", line);
  }

  const grpc::ServerContextBase* const context_;
  const std::string method_;
  const bool streaming_;
  const bool single_request_;  // unary or server streaming: exactly one request
  Metrics* const metrics_;
  bool recognition_answers_ = false;  // only with metrics
  const std::chrono::steady_clock::time_point start_;
  std::string request_id_;
  std::string peer_;
  // A bidirectional stream may read on one thread while another writes.
  std::atomic<int64_t> received_{0};
  bool unparsable_request_ = false;  // a single request that did not parse
  std::atomic<int64_t> sent_{0};
  std::atomic<bool> finished_{false};
};

class CallInterceptorFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit CallInterceptorFactory(Metrics* metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(ServerRpcInfo* info) override {
    return new CallInterceptor(info, metrics_);
  }

 private:
  Metrics* const metrics_;
};

}  // namespace

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeCallInterceptorFactory(
    Metrics* metrics) {
  return std::make_unique<CallInterceptorFactory>(metrics);
}

}  // namespace waymark::service

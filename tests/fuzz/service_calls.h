#ifndef WAYMARK_TESTS_FUZZ_SERVICE_CALLS_H_
#define WAYMARK_TESTS_FUZZ_SERVICE_CALLS_H_

// What the request targets (crossing_requests.cc, slam_requests.cc, token_requests.cc) share: their
// input format and calling a service's handler as gRPC would, without a network.
//
// An input is one byte that picks the RPC (modulo the service's count) followed by the bytes of
// that RPC's request message. Inputs whose message does not parse are dropped, as gRPC drops them
// before any handler runs; everything after parsing (validation, translation into the engines'
// types, the registry and its in-memory store) is the server's own code.

#include <google/protobuf/message.h>
#include <google/protobuf/message_lite.h>
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/server_context.h>
#include <spdlog/spdlog.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <string>
#include <utility>

#include "absl/status/status.h"

namespace waymark::fuzz {

// Aborts, a crash both drivers report, when a target's own setup fails or a property it checks
// breaks; `what` says which.
inline void Require(const absl::Status& status, const char* what) {
  if (status.ok()) return;
  std::fprintf(stderr, "fuzz: %s: %s\n", what, status.ToString().c_str());
  std::abort();
}
inline void Require(bool holds, const char* what) {
  Require(holds ? absl::OkStatus() : absl::InternalError("does not hold"), what);
}

// Silences the server's log and protobuf's (which reports every string field that is not UTF-8):
// millions of lines would slow the run and bury a crash's report.
inline void QuietLogs() {
  spdlog::set_level(spdlog::level::off);
  google::protobuf::SetLogHandler(
      [](google::protobuf::LogLevel, const char*, int, const std::string&) {});
}

// An input of a request target: `rpc` picks the call, `message` its request.
struct RequestInput {
  uint8_t rpc = 0;
  const uint8_t* message = nullptr;
  size_t size = 0;
};
inline std::optional<RequestInput> SplitRequestInput(const uint8_t* data, size_t size) {
  if (size == 0) return std::nullopt;
  return RequestInput{data[0], data + 1, size - 1};
}

// The seed of a request target for `request` sent to RPC number `rpc`.
inline std::string RequestSeed(uint8_t rpc, const google::protobuf::MessageLite& request) {
  return std::string(1, static_cast<char>(rpc)) + request.SerializeAsString();
}

template <class Request>
std::optional<Request> ParseRequest(const RequestInput& input) {
  Request request;
  if (!request.ParseFromArray(input.message, static_cast<int>(input.size))) return std::nullopt;
  return request;
}

// Where the answers of the calls go when someone wants them (waymark-fuzz --answers, issue 35):
// every response of a call that succeeded, every stream update, and the status of every call
// that failed (`response` null). Unset (the default): nowhere.
using AnswerSink =
    std::function<void(const google::protobuf::Message* response, const grpc::Status& status)>;
inline AnswerSink& Answers() {
  static AnswerSink* sink = new AnswerSink;  // never destroyed: fixtures outlive main
  return *sink;
}
inline void RecordAnswer(const google::protobuf::Message* response, const grpc::Status& status) {
  if (Answers()) Answers()(response, status);
}

// Runs a unary handler (`&Service::Method`) on `request` with a fresh server context (the
// services' authenticators are off: admin calls), as gRPC's sync server does. The response when
// the call succeeded. Either goes to the answer sink.
template <class Service, class Request, class Response>
std::optional<Response> CallUnary(Service& service,
                                  grpc::Status (Service::*method)(grpc::ServerContext*,
                                                                  const Request*, Response*),
                                  const Request& request) {
  grpc::ServerContext context;
  Response response;
  const grpc::Status status = (service.*method)(&context, &request, &response);
  RecordAnswer(status.ok() ? &response : nullptr, status);
  if (!status.ok()) return std::nullopt;
  return response;
}

// One RPC of a request target: parses the input's message as its request and serves it.
using RpcHandler = std::function<void(const RequestInput& input)>;

// What UnaryRpc does before and after the call when not told otherwise: nothing.
struct NoPrepare {
  template <class Request>
  void operator()(Request*) const {}
};
struct NoCheck {
  template <class Request, class Response>
  void operator()(const Request&, const Response&) const {}
};

// The RpcHandler of `method` on `service`: `prepare(&request)` may rewrite the parsed request
// first (e.g. name the target's own sessions), `check(request, response)` judges a successful
// answer (abort on a broken property).
template <class Service, class Request, class Response, class Prepare = NoPrepare,
          class Check = NoCheck>
RpcHandler UnaryRpc(Service* service,
                    grpc::Status (Service::*method)(grpc::ServerContext*, const Request*,
                                                    Response*),
                    Check check = {}, Prepare prepare = {}) {
  return [service, method, check = std::move(check),
          prepare = std::move(prepare)](const RequestInput& input) {
    std::optional<Request> request = ParseRequest<Request>(input);
    if (!request.has_value()) return;
    prepare(&*request);
    if (std::optional<Response> response = CallUnary(*service, method, *request)) {
      check(*request, *response);
    }
  };
}

}  // namespace waymark::fuzz

#endif  // WAYMARK_TESTS_FUZZ_SERVICE_CALLS_H_

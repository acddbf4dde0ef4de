#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_CALLS_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_CALLS_H_

// waymark-hostile-campaign: one call of any method as raw bytes through grpc::GenericStub, so the
// campaign can send what a typed stub cannot (bytes that do not parse, two messages to a unary
// method, a stream cancelled half way). A call is a script of steps run in order; every call
// has a deadline, so a server that never answers shows up as DEADLINE_EXCEEDED, not a stuck
// campaign.

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace waymark::bench::hostile {

enum class StepKind {
  kWrite,       // send `bytes` as one message
  kWritesDone,  // half-close: the client sends nothing more
  kReadOne,     // wait for one answer
  kReadAll,     // read answers until the server ends the call
  kCancel,      // the client gives up (TryCancel): the stream ends abruptly
};

struct Step {
  StepKind kind = StepKind::kWrite;
  std::string bytes;       // kWrite only
  bool malformed = false;  // kWrite: a mutated message, not a valid one
  bool parses = true;      // kWrite: the bytes parse as the method's request type
  std::string mutation;    // kWrite of a malformed message: the operators applied
};

// What one call sends: the method, its metadata and its steps.
struct CallInput {
  std::string method;  // "/package.Service/Method"
  std::string shape;   // how the steps were chosen ("unary", "mixed", "cancel_mid_stream", ...)
  std::vector<std::pair<std::string, std::string>> metadata;
  std::vector<Step> steps;

  int MalformedMessages() const;
  // Some malformed message does not parse as the request type (the server cannot read it).
  bool SendsUnparsable() const;
  bool ClientCancels() const;
  // The operators of every malformed message, "+"-joined per message, ","-joined over them.
  std::string Mutations() const;
};

// What came back.
struct CallOutcome {
  grpc::StatusCode code = grpc::StatusCode::UNKNOWN;
  std::string message;               // the status message
  std::vector<std::string> answers;  // raw answer messages, in order
  double ms = 0;                     // from the start of the call to its status
  bool write_refused = false;        // a write failed: the server had ended the call before it
};

// Runs `input` on `stub`; every wait goes through `cq` (one per thread, no other user).
CallOutcome RunCall(grpc::GenericStub& stub, grpc::CompletionQueue& cq, const CallInput& input,
                    std::chrono::seconds deadline);

// The call as JSON (bytes base64), to save an input that made the server misbehave, and back.
nlohmann::json CallInputToJson(const CallInput& input);
CallInput CallInputFromJson(const nlohmann::json& json);

// "OK", "INVALID_ARGUMENT", ... as gRPC spells the codes.
std::string CodeName(grpc::StatusCode code);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_CALLS_H_

#include "bench/robustness/hostile_campaign_shapes.h"

#include <set>

namespace waymark::bench::hostile {
namespace {

using grpc::StatusCode;

// Builds one call's steps from a target's valid messages.
class StepBuilder {
 public:
  StepBuilder(const RpcTarget& target, const Mutator* mutator, int thread, Rng& rng)
      : type_(target.method->input_type()), mutator_(mutator), rng_(rng),
        source_(target.begin_call(thread, rng)) {}

  StepBuilder& Valid(int count = 1) {
    for (int i = 0; i < count; ++i) {
      Step step;
      step.bytes = source_()->SerializeAsString();
      steps_.push_back(std::move(step));
    }
    return *this;
  }
  StepBuilder& Malformed(int count = 1) {
    for (int i = 0; i < count; ++i) {
      const Mutation mutation = mutator_->Mutate(*source_(), rng_);
      Step step;
      step.malformed = true;
      step.parses = Parses(type_, mutation.bytes);
      step.mutation = mutation.kind;
      step.bytes = mutation.bytes;
      steps_.push_back(std::move(step));
    }
    return *this;
  }
  StepBuilder& Then(StepKind kind) {
    Step step;
    step.kind = kind;
    steps_.push_back(std::move(step));
    return *this;
  }
  std::vector<Step> Take() { return std::move(steps_); }

 private:
  const google::protobuf::Descriptor* type_;
  const Mutator* mutator_;
  Rng& rng_;
  MessageSource source_;
  std::vector<Step> steps_;
};

int Between(Rng& rng, int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }

// Picks a shape by weight.
template <size_t N>
const char* PickShape(Rng& rng, const std::pair<const char*, int> (&shapes)[N]) {
  std::vector<int> weights;
  for (const auto& shape : shapes) weights.push_back(shape.second);
  return shapes[std::discrete_distribution<size_t>(weights.begin(), weights.end())(rng)].first;
}

std::vector<Step> UnaryShape(const std::string& shape, StepBuilder& b) {
  if (shape == "unary_two_messages") b.Malformed().Valid();
  if (shape == "unary") b.Malformed();
  return b.Then(StepKind::kWritesDone).Then(StepKind::kReadAll).Take();
}

// `bidi`: the server answers each message (a client stream answers once, after the half-close,
// so waiting for an answer before cancelling would only wait for the deadline).
std::vector<Step> ClientStreamShape(const std::string& shape, StepBuilder& b, Rng& rng, bool bidi) {
  if (shape == "one_malformed") b.Malformed().Then(StepKind::kWritesDone);
  if (shape == "mixed") b.Valid(Between(rng, 1, 3)).Malformed().Valid(Between(rng, 1, 3)).Then(StepKind::kWritesDone);
  if (shape == "all_malformed") b.Malformed(Between(rng, 2, 5)).Then(StepKind::kWritesDone);
  if (shape == "cancel_mid_stream") {
    b.Valid().Malformed();
    if (bidi) b.Then(StepKind::kReadOne);
    b.Then(StepKind::kCancel);
  }
  if (shape == "half_close_early") b.Valid(Between(rng, 0, 1)).Then(StepKind::kWritesDone);
  if (shape == "abandoned") b.Malformed().Valid().Then(StepKind::kCancel);
  return b.Then(StepKind::kReadAll).Take();
}

std::vector<Step> ServerStreamShape(const std::string& shape, StepBuilder& b) {
  if (shape == "two_requests") b.Malformed().Valid();
  if (shape != "two_requests") b.Malformed();
  b.Then(StepKind::kWritesDone);
  if (shape != "cancel_at_once") b.Then(StepKind::kReadOne);
  return b.Then(StepKind::kCancel).Take();
}

// Steps of the valid call: the request(s) and, for a server stream that never ends, a cancel
// after the first answer.
std::vector<Step> ValidSteps(const RpcTarget& target, StepBuilder& b) {
  switch (target.kind) {
    case RpcKind::kUnary:
      return b.Valid().Then(StepKind::kWritesDone).Then(StepKind::kReadAll).Take();
    case RpcKind::kServerStream:
      return b.Valid().Then(StepKind::kWritesDone).Then(StepKind::kReadOne).Then(StepKind::kCancel).Take();
    case RpcKind::kClientStream:
    case RpcKind::kBidiStream:
      break;
  }
  return b.Valid(3).Then(StepKind::kWritesDone).Then(StepKind::kReadAll).Take();
}

}  // namespace

CallInput ValidCall(const RpcTarget& target, int thread, Rng& rng) {
  StepBuilder builder(target, nullptr, thread, rng);
  CallInput input;
  input.method = target.path;
  input.shape = "valid";
  input.steps = ValidSteps(target, builder);
  return input;
}

PlannedCall PlanHostileCall(const RpcTarget& target, const Mutator& mutator, int thread, Rng& rng,
                            bool seed_call) {
  PlannedCall call;
  call.target = &target;
  if (seed_call) {
    call.input = ValidCall(target, thread, rng);
    call.input.shape = "seed";
    call.cost = 0;
    return call;
  }
  static const std::pair<const char*, int> kUnary[] = {
      {"unary", 96}, {"unary_two_messages", 2}, {"unary_no_message", 2}};
  static const std::pair<const char*, int> kClient[] = {
      {"one_malformed", 25}, {"mixed", 30}, {"all_malformed", 15},
      {"cancel_mid_stream", 15}, {"half_close_early", 10}, {"abandoned", 5}};
  static const std::pair<const char*, int> kServer[] = {
      {"first_answer_then_cancel", 70}, {"cancel_at_once", 20}, {"two_requests", 10}};
  StepBuilder builder(target, &mutator, thread, rng);
  call.input.method = target.path;
  switch (target.kind) {
    case RpcKind::kUnary:
      call.input.shape = PickShape(rng, kUnary);
      call.input.steps = UnaryShape(call.input.shape, builder);
      break;
    case RpcKind::kServerStream:
      call.input.shape = PickShape(rng, kServer);
      call.input.steps = ServerStreamShape(call.input.shape, builder);
      break;
    case RpcKind::kClientStream:
    case RpcKind::kBidiStream:
      call.input.shape = PickShape(rng, kClient);
      call.input.steps =
          ClientStreamShape(call.input.shape, builder, rng, target.kind == RpcKind::kBidiStream);
      break;
  }
  call.cost = call.input.MalformedMessages();
  return call;
}

std::vector<std::string> JudgeHostile(const PlannedCall& call, const CallOutcome& outcome,
                                      const CallOutcome* previous) {
  static const std::set<StatusCode> kClientErrors = {
      StatusCode::INVALID_ARGUMENT, StatusCode::NOT_FOUND, StatusCode::ALREADY_EXISTS,
      StatusCode::FAILED_PRECONDITION, StatusCode::OUT_OF_RANGE, StatusCode::RESOURCE_EXHAUSTED};
  std::vector<std::string> anomalies;
  const StatusCode code = outcome.code;
  if (code == StatusCode::DEADLINE_EXCEEDED) {
    anomalies.push_back("possible_hang");
  } else if (code == StatusCode::UNKNOWN || code == StatusCode::INTERNAL ||
             code == StatusCode::DATA_LOSS) {
    anomalies.push_back(call.input.SendsUnparsable()  ? "server_error_for_unparsable"
                        : call.input.steps.size() > 0 &&
                                  call.input.steps.front().kind != StepKind::kWrite
                            ? "server_error_for_no_message"
                            : "server_error_for_parsable");
  } else if (HeadersOverLimit(outcome)) {
    // The client sent no metadata: the server's answer headers (its status message) were over
    // the client's limit, and the client never learns the real status.
    anomalies.push_back("answer_headers_over_client_limit");
  } else if (AfterClosedConnection(outcome, previous)) {
    anomalies.push_back("unavailable_after_oversized_headers");
  } else if (code == StatusCode::OK) {
    if (call.input.SendsUnparsable()) anomalies.push_back("ok_for_unparsable");
  } else if (code == StatusCode::CANCELLED) {
    if (!call.input.ClientCancels()) anomalies.push_back("cancelled_without_client_cancel");
  } else if (kClientErrors.count(code) == 0) {
    anomalies.push_back("unexpected_" + CodeName(code));
  }
  if (call.input.shape == "seed" && code != StatusCode::OK && code != StatusCode::CANCELLED) {
    anomalies.push_back("seed_refused");
  }
  return anomalies;
}

}  // namespace waymark::bench::hostile

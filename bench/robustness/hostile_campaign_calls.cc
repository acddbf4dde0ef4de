#include "bench/robustness/hostile_campaign_calls.h"

#include <map>

#include "absl/strings/escaping.h"
#include "absl/strings/str_join.h"

namespace waymark::bench::hostile {
namespace {

using Clock = std::chrono::steady_clock;

// Waits for the one operation in flight on `cq` (the steps run one at a time, so the next event is
// always it); false when it failed (the call is over on that side).
bool Await(grpc::CompletionQueue& cq) {
  void* tag = nullptr;
  bool ok = false;
  if (!cq.Next(&tag, &ok)) return false;
  return ok;
}

std::string Flatten(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& slice : slices) bytes.append(slice.begin(), slice.end());
  return bytes;
}

grpc::ByteBuffer Buffer(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

const std::map<StepKind, std::string>& StepNames() {
  static const auto* names = new std::map<StepKind, std::string>{
      {StepKind::kWrite, "write"},     {StepKind::kWritesDone, "writes_done"},
      {StepKind::kReadOne, "read_one"}, {StepKind::kReadAll, "read_all"},
      {StepKind::kCancel, "cancel"}};
  return *names;
}

// The state of one call while its steps run.
class ScriptedCall {
 public:
  ScriptedCall(grpc::GenericStub& stub, grpc::CompletionQueue& cq, const CallInput& input,
               std::chrono::seconds deadline)
      : cq_(cq) {
    context_.set_deadline(std::chrono::system_clock::now() + deadline);
    for (const auto& [key, value] : input.metadata) context_.AddMetadata(key, value);
    call_ = stub.PrepareCall(&context_, input.method, &cq_);
    if (call_ != nullptr) {
      call_->StartCall(this);
      started_ = Await(cq_);
    }
    writable_ = readable_ = started_;
    ended_ = !started_;
  }

  void Run(const Step& step, CallOutcome& out) {
    switch (step.kind) {
      case StepKind::kWrite: Write(step.bytes, out); break;
      case StepKind::kWritesDone: WritesDone(); break;
      case StepKind::kReadOne: ReadOne(out); break;
      case StepKind::kReadAll: while (ReadOne(out)) {} break;
      case StepKind::kCancel: Cancel(); break;
    }
  }

  // The status; a call the client did not cancel is read to its end first (gRPC wants every
  // answer read before the status).
  grpc::Status Finish(CallOutcome& out) {
    if (call_ == nullptr) return grpc::Status(grpc::StatusCode::INTERNAL, "no call");
    if (!cancelled_) {
      WritesDone();
      while (ReadOne(out)) {}
    }
    grpc::Status status;
    call_->Finish(&status, this);
    Await(cq_);
    return status;
  }

 private:
  // A call the server has ended already is not cancelled: its status is the server's answer,
  // which a cancel would hide behind CANCELLED.
  void Cancel() {
    if (ended_) return;
    context_.TryCancel();
    cancelled_ = true;
  }
  void Write(const std::string& bytes, CallOutcome& out) {
    if (!writable_) {
      out.write_refused = true;
      return;
    }
    call_->Write(Buffer(bytes), this);
    if (!Await(cq_)) {
      writable_ = false;
      ended_ = true;
      out.write_refused = true;
    }
  }
  void WritesDone() {
    if (!writable_) return;
    call_->WritesDone(this);
    Await(cq_);
    writable_ = false;
  }
  bool ReadOne(CallOutcome& out) {
    if (!readable_ || cancelled_) return false;
    grpc::ByteBuffer buffer;
    call_->Read(&buffer, this);
    if (!Await(cq_)) {
      readable_ = false;
      ended_ = true;
      return false;
    }
    out.answers.push_back(Flatten(buffer));
    return true;
  }

  grpc::CompletionQueue& cq_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  bool started_ = false;
  bool writable_ = false;
  bool readable_ = false;
  bool cancelled_ = false;
  bool ended_ = false;  // a read or write failed: the server has ended the call
};

}  // namespace

int CallInput::MalformedMessages() const {
  int n = 0;
  for (const Step& step : steps) n += step.kind == StepKind::kWrite && step.malformed;
  return n;
}

bool CallInput::SendsUnparsable() const {
  for (const Step& step : steps) {
    if (step.kind == StepKind::kWrite && !step.parses) return true;
  }
  return false;
}

bool CallInput::ClientCancels() const {
  for (const Step& step : steps) {
    if (step.kind == StepKind::kCancel) return true;
  }
  return false;
}

std::string CallInput::Mutations() const {
  std::vector<std::string> kinds;
  for (const Step& step : steps) {
    if (step.kind == StepKind::kWrite && step.malformed) kinds.push_back(step.mutation);
  }
  return absl::StrJoin(kinds, ",");
}

CallOutcome RunCall(grpc::GenericStub& stub, grpc::CompletionQueue& cq, const CallInput& input,
                    std::chrono::seconds deadline) {
  const Clock::time_point start = Clock::now();
  CallOutcome out;
  ScriptedCall call(stub, cq, input, deadline);
  for (const Step& step : input.steps) call.Run(step, out);
  const grpc::Status status = call.Finish(out);
  out.code = status.error_code();
  out.message = status.error_message();
  out.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  return out;
}

nlohmann::json CallInputToJson(const CallInput& input) {
  nlohmann::json steps = nlohmann::json::array();
  for (const Step& step : input.steps) {
    nlohmann::json s = {{"step", StepNames().at(step.kind)}};
    if (step.kind == StepKind::kWrite) {
      s["bytes_base64"] = absl::Base64Escape(step.bytes);
      s["size"] = step.bytes.size();
      s["malformed"] = step.malformed;
      s["parses"] = step.parses;
      if (step.malformed) s["mutation"] = step.mutation;
    }
    steps.push_back(s);
  }
  nlohmann::json metadata = nlohmann::json::array();
  for (const auto& [key, value] : input.metadata) {
    // Values can be megabytes (the oversized-metadata case): keep their size and a prefix.
    metadata.push_back({{"key", key},
                        {"value", value.size() > 256 ? value.substr(0, 256) + "..." : value},
                        {"size", value.size()}});
  }
  return {{"method", input.method}, {"shape", input.shape}, {"metadata", metadata},
          {"steps", steps}};
}

CallInput CallInputFromJson(const nlohmann::json& json) {
  CallInput input;
  input.method = json.at("method").get<std::string>();
  input.shape = json.value("shape", "");
  for (const nlohmann::json& m : json.value("metadata", nlohmann::json::array())) {
    input.metadata.emplace_back(m.at("key").get<std::string>(), m.at("value").get<std::string>());
  }
  for (const nlohmann::json& s : json.at("steps")) {
    Step step;
    for (const auto& [kind, name] : StepNames()) {
      if (name == s.at("step").get<std::string>()) step.kind = kind;
    }
    if (step.kind == StepKind::kWrite) {
      absl::Base64Unescape(s.at("bytes_base64").get<std::string>(), &step.bytes);
      step.malformed = s.value("malformed", false);
      step.parses = s.value("parses", true);
      step.mutation = s.value("mutation", "");
    }
    input.steps.push_back(step);
  }
  return input;
}

std::string CodeName(grpc::StatusCode code) {
  static const char* const kNames[] = {
      "OK",           "CANCELLED",         "UNKNOWN",        "INVALID_ARGUMENT",
      "DEADLINE_EXCEEDED", "NOT_FOUND",    "ALREADY_EXISTS", "PERMISSION_DENIED",
      "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION", "ABORTED", "OUT_OF_RANGE",
      "UNIMPLEMENTED", "INTERNAL",         "UNAVAILABLE",    "DATA_LOSS",
      "UNAUTHENTICATED"};
  const int index = static_cast<int>(code);
  return index >= 0 && index < 17 ? kNames[index] : "CODE_" + std::to_string(index);
}

}  // namespace waymark::bench::hostile

#include "bench/robustness/hostile_campaign_runner.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"

namespace waymark::bench::hostile {
namespace {

namespace fs = std::filesystem;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

constexpr size_t kJournalLength = 8;  // calls kept per thread for a crash record
constexpr int kMaxCrashesPerBatch = 3;

// The first field holding NaN or infinity anywhere in `m` ("" when none does).
std::string NonFiniteField(const Message& m) {
  const google::protobuf::Reflection* r = m.GetReflection();
  std::vector<const FieldDescriptor*> fields;
  r->ListFields(m, &fields);
  for (const FieldDescriptor* f : fields) {
    const int n = f->is_repeated() ? r->FieldSize(m, f) : 1;
    for (int i = 0; i < n; ++i) {
      switch (f->cpp_type()) {
        case FieldDescriptor::CPPTYPE_DOUBLE:
          if (!std::isfinite(f->is_repeated() ? r->GetRepeatedDouble(m, f, i) : r->GetDouble(m, f))) return f->full_name();
          break;
        case FieldDescriptor::CPPTYPE_FLOAT:
          if (!std::isfinite(f->is_repeated() ? r->GetRepeatedFloat(m, f, i) : r->GetFloat(m, f))) return f->full_name();
          break;
        case FieldDescriptor::CPPTYPE_MESSAGE: {
          std::string inner = NonFiniteField(f->is_repeated() ? r->GetRepeatedMessage(m, f, i) : r->GetMessage(m, f));
          if (!inner.empty()) return inner;
          break;
        }
        default:
          break;
      }
    }
  }
  return "";
}

// Removes `prefix`* (a database with its WAL, lock and server logs).
void RemoveFilesStartingWith(const std::string& prefix) {
  const fs::path path(prefix);
  for (const auto& entry : fs::directory_iterator(path.parent_path())) {
    if (entry.path().filename().string().rfind(path.filename().string(), 0) == 0) {
      std::error_code ignored;
      fs::remove(entry.path(), ignored);
    }
  }
}

// Copies the SQLite file with its WAL (what a server left behind) to `to`.
void CopyDatabase(const std::string& from, const std::string& to) {
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ignored;
    fs::remove(to + suffix, ignored);
    if (fs::exists(from + suffix)) fs::copy_file(from + suffix, to + suffix, ignored);
  }
}

// A connection of its own (gRPC shares one between channels to the same address unless told
// not to): each campaign thread is a robot, and what one robot's bad call does to its own
// connection must not fail the others' calls. client::MakeChannel has no such option.
std::shared_ptr<grpc::Channel> OwnConnection(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  args.SetMaxSendMessageSize(64 << 20);
  args.SetMaxReceiveMessageSize(64 << 20);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

std::string Tail(const std::string& log, size_t lines) {
  size_t at = log.size();
  for (size_t n = 0; n <= lines && at > 0; ++n) at = log.rfind('\n', at - 1);
  return at == std::string::npos ? log : log.substr(at + 1);
}

}  // namespace

struct Runner::Journal {
  std::mutex mutex;
  std::deque<std::shared_ptr<const CallInput>> calls;  // newest first; front = in flight

  void Push(std::shared_ptr<const CallInput> call) {
    std::lock_guard<std::mutex> lock(mutex);
    calls.push_front(std::move(call));
    if (calls.size() > kJournalLength) calls.pop_back();
  }
  std::deque<std::shared_ptr<const CallInput>> Snapshot() {
    std::lock_guard<std::mutex> lock(mutex);
    return calls;
  }
};

// Codes of the per-message rejections in `m`: fields named error_code, and Rejection.code.
void CollectRejections(const Message& m, std::vector<int>* codes) {
  const google::protobuf::Reflection* r = m.GetReflection();
  std::vector<const FieldDescriptor*> fields;
  r->ListFields(m, &fields);
  for (const FieldDescriptor* f : fields) {
    if (f->cpp_type() == FieldDescriptor::CPPTYPE_INT32 && !f->is_repeated() &&
        (f->name() == "error_code" || (f->name() == "code" && m.GetDescriptor()->name() == "Rejection"))) {
      codes->push_back(r->GetInt32(m, f));
    } else if (f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
      const int n = f->is_repeated() ? r->FieldSize(m, f) : 1;
      for (int i = 0; i < n; ++i) {
        CollectRejections(f->is_repeated() ? r->GetRepeatedMessage(m, f, i) : r->GetMessage(m, f), codes);
      }
    }
  }
}

AnswerReport InspectAnswers(const RpcTarget& target, const CallOutcome& outcome) {
  AnswerReport report;
  const Message* prototype = google::protobuf::MessageFactory::generated_factory()->GetPrototype(
      target.method->output_type());
  std::set<std::string> seen;  // each anomaly once per call
  const auto add = [&](const std::string& anomaly) {
    if (seen.insert(anomaly).second) report.anomalies.push_back(anomaly);
  };
  for (const std::string& bytes : outcome.answers) {
    std::unique_ptr<Message> answer(prototype->New());
    if (!answer->ParseFromString(bytes)) {
      add("unparsable_answer");
      continue;
    }
    if (const std::string field = NonFiniteField(*answer); !field.empty()) {
      add("non_finite_answer:" + field);
    }
    std::vector<int> codes;
    CollectRejections(*answer, &codes);
    for (int code : codes) {
      const auto status = static_cast<grpc::StatusCode>(code);
      if (status == grpc::StatusCode::UNKNOWN || status == grpc::StatusCode::INTERNAL ||
          status == grpc::StatusCode::DATA_LOSS) {
        add("server_error_in_stream_answer:" + CodeName(status));
      }
      report.rejection_codes.push_back(code);
    }
  }
  return report;
}

Runner::Runner(WatchedServer* server, SampleSaver* samples, RunnerOptions options)
    : server_(server), samples_(samples), options_(std::move(options)) {
  if (!options_.trace.empty()) trace_.open(options_.trace, std::ios::app);
}

void Runner::Trace(const Batch& batch, int thread, const CallInput& input,
                   const CallOutcome& outcome) {
  if (!trace_.is_open()) return;
  nlohmann::json sizes = nlohmann::json::array();
  for (const Step& step : input.steps) {
    if (step.kind == StepKind::kWrite) sizes.push_back(step.bytes.size());
  }
  const nlohmann::json line = {
      {"batch", batch.name}, {"thread", thread},         {"shape", input.shape},
      {"mutations", input.Mutations()}, {"sizes", sizes}, {"code", CodeName(outcome.code)},
      {"message", outcome.message.substr(0, 200)},        {"ms", outcome.ms}};
  std::lock_guard<std::mutex> lock(trace_mutex_);
  trace_ << line.dump() << "\n";
}

bool HeadersOverLimit(const CallOutcome& outcome) {
  return outcome.code == grpc::StatusCode::RESOURCE_EXHAUSTED &&
         outcome.message.find("metadata size exceeds limit") != std::string::npos;
}

bool AfterClosedConnection(const CallOutcome& outcome, const CallOutcome* previous) {
  return outcome.code == grpc::StatusCode::UNAVAILABLE && previous != nullptr &&
         HeadersOverLimit(*previous);
}

nlohmann::json CrashRecord::ToJson() const {
  return {{"batch", batch}, {"exit_code", exit_code}, {"dir", dir}, {"reproduced_by", reproduced_by}};
}

void Runner::Worker(const Batch& batch, int thread, std::atomic<int64_t>& spent,
                    std::atomic<int64_t>& index, std::map<std::string, RpcStats>& stats,
                    Journal& journal, int64_t max_calls) {
  Rng rng(options_.seed * 0x9e3779b97f4a7c15ULL + std::hash<std::string>()(batch.name) +
          static_cast<uint64_t>(thread) * 7919);
  grpc::GenericStub stub(OwnConnection(server_->address()));
  grpc::CompletionQueue cq;
  int64_t calls = 0;
  std::optional<CallOutcome> previous;
  int64_t next_report = batch.budget / 10;
  while ((max_calls < 0 || calls++ < max_calls) && server_->Alive()) {
    const int64_t call_index = index.fetch_add(1);
    PlannedCall call = batch.plan(thread, rng, call_index);
    const int64_t before = spent.fetch_add(call.cost);
    if (before >= batch.budget) break;
    auto input = std::make_shared<const CallInput>(call.input);
    journal.Push(input);
    const CallOutcome outcome = RunCall(stub, cq, *input, options_.deadline);
    Trace(batch, thread, *input, outcome);
    std::vector<std::string> anomalies =
        batch.judge(call, outcome, previous.has_value() ? &*previous : nullptr);
    // An UNAVAILABLE nothing else explains: the server may be dying (a process that crashed
    // takes a moment to be reaped). Then it is the crash, not this call's status.
    const bool unexplained = std::any_of(anomalies.begin(), anomalies.end(), [](const std::string& a) {
      return a.find("UNAVAILABLE") != std::string::npos;
    });
    if (outcome.code == grpc::StatusCode::UNAVAILABLE &&
        (!server_->Alive() || (unexplained && server_->DiesWithin(std::chrono::milliseconds(300))))) {
      anomalies = {"in_flight_when_the_server_died"};
    }
    const AnswerReport answers = InspectAnswers(*call.target, outcome);
    anomalies.insert(anomalies.end(), answers.anomalies.begin(), answers.anomalies.end());
    RpcStats& mine = stats[call.target->name];
    mine.Record(*input, outcome, anomalies, answers.rejection_codes);
    const std::string sample_key =
        batch.name == call.target->name ? batch.name : batch.name + "/" + call.target->name;
    for (const std::string& anomaly : anomalies) samples_->Save(sample_key, anomaly, *input, outcome);
    if (outcome.code == grpc::StatusCode::OK && call.target->on_ok) {
      const std::string first = input->steps.empty() ? "" : input->steps.front().bytes;
      call.target->on_ok(first, outcome.answers);
    }
    previous = outcome;
    if (thread == 0 && before >= next_report) {
      std::fprintf(stderr, "  %s: %lld / %lld\n", batch.name.c_str(),
                   static_cast<long long>(before), static_cast<long long>(batch.budget));
      next_report += batch.budget / 10;
    }
  }
  cq.Shutdown();
  void* tag;
  bool ok;
  while (cq.Next(&tag, &ok)) {}
}

std::map<std::string, RpcStats> Runner::Run(const Batch& batch) {
  std::atomic<int64_t> spent{0}, index{0};
  std::vector<std::map<std::string, RpcStats>> per_thread(options_.threads);
  std::vector<Journal> journals(options_.threads);
  // The batch's first call alone (the valid request, for the hostile batches), so no mutation
  // sent beside it consumes what it addresses first.
  Worker(batch, 0, spent, index, per_thread[0], journals[0], 1);
  for (int crashes = 0;; ++crashes) {
    std::vector<std::thread> threads;
    for (int t = 0; t < options_.threads; ++t) {
      threads.emplace_back([&, t] { Worker(batch, t, spent, index, per_thread[t], journals[t]); });
    }
    for (std::thread& t : threads) t.join();
    if (server_->Alive()) break;
    crashes_.push_back(RecordCrash(batch, journals));
    std::fprintf(stderr, "  %s: THE SERVER DIED (exit %d); inputs in %s\n", batch.name.c_str(),
                 crashes_.back().exit_code, crashes_.back().dir.c_str());
    if (absl::Status s = server_->Restart(); !s.ok()) {
      std::fprintf(stderr, "  cannot restart the server: %s\n", s.ToString().c_str());
      break;
    }
    if (spent.load() >= batch.budget || crashes + 1 >= kMaxCrashesPerBatch) break;
  }
  std::map<std::string, RpcStats> merged;
  for (const auto& stats : per_thread) {
    for (const auto& [name, s] : stats) merged[name].Merge(s);
  }
  return merged;
}

CrashRecord Runner::RecordCrash(const Batch& batch, std::vector<Journal>& journals) {
  CrashRecord record;
  record.batch = batch.name;
  record.exit_code = server_->ExitCode().value_or(-1);
  record.dir = absl::StrCat(options_.out, "/crashes/", crashes_.size(), "-", FileSafe(batch.name));
  fs::create_directories(record.dir);
  std::ofstream(record.dir + "/server.log.tail") << Tail(server_->Log(), 200);
  const std::string db_copy = record.dir + "/waymark.db";
  CopyDatabase(server_->db(), db_copy);
  std::vector<std::string> inputs;
  for (size_t t = 0; t < journals.size(); ++t) {
    const auto calls = journals[t].Snapshot();
    for (size_t age = 0; age < calls.size(); ++age) {
      const std::string path = absl::StrCat(record.dir, "/thread", t, "-", age == 0 ? "in-flight" : absl::StrCat("previous", age), ".json");
      WriteCallFile(path, *calls[age], nullptr);
      inputs.push_back(path);
    }
  }
  if (options_.replay_crashes) record.reproduced_by = Replay(db_copy, inputs);
  return record;
}

// Each input alone against a server on a copy of the crashed server's database: those after
// which the server is gone.
std::vector<std::string> Runner::Replay(const std::string& db_copy,
                                        const std::vector<std::string>& inputs) {
  std::vector<std::string> killers;
  const std::string work = db_copy + ".replay";
  for (const std::string& path : inputs) {
    CopyDatabase(db_copy, work);
    auto server = testing::ServerProcess::Start(testing::ServerBinary(), work);
    if (!server.ok()) continue;
    std::ifstream file(path);
    const CallInput input = CallInputFromJson(nlohmann::json::parse(file));
    grpc::GenericStub stub(OwnConnection((*server)->address()));
    grpc::CompletionQueue cq;
    RunCall(stub, cq, input, options_.deadline);
    cq.Shutdown();
    void* tag;
    bool ok;
    while (cq.Next(&tag, &ok)) {}
    // A crash after the answer (a session worker processing the message) takes a moment.
    if ((*server)->WaitForExit(absl::Seconds(2)).has_value()) {
      killers.push_back(path);
      std::ofstream(path + ".replay.log") << (*server)->Log();
    }
    server->reset();
    RemoveFilesStartingWith(work);
  }
  return killers;
}

}  // namespace waymark::bench::hostile

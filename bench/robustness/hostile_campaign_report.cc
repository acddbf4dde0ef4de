#include "bench/robustness/hostile_campaign_report.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace waymark::bench::hostile {
namespace {

constexpr size_t kMessagesPerCode = 4;
constexpr size_t kMessageChars = 240;

std::vector<std::pair<std::string, int64_t>> ByCount(const std::map<std::string, int64_t>& counts) {
  std::vector<std::pair<std::string, int64_t>> sorted(counts.begin(), counts.end());
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return sorted;
}

}  // namespace

void RpcStats::Record(const CallInput& input, const CallOutcome& outcome,
                      const std::vector<std::string>& anomalies, const std::vector<int>& rejections) {
  for (int code : rejections) ++rejection_codes_[CodeName(static_cast<grpc::StatusCode>(code))];
  ++calls_;
  for (const Step& step : input.steps) {
    if (step.kind != StepKind::kWrite) continue;
    ++messages_;
    malformed_ += step.malformed;
    unparsable_ += !step.parses;
  }
  write_refused_ += outcome.write_refused;
  answers_ += static_cast<int64_t>(outcome.answers.size());
  const std::string code = CodeName(outcome.code);
  ++codes_[code];
  ++codes_by_shape_[input.shape][code];
  std::vector<std::string> operators;
  for (absl::string_view kinds : absl::StrSplit(input.Mutations(), absl::ByAnyChar(",+"), absl::SkipEmpty())) {
    if (std::find(operators.begin(), operators.end(), kinds) == operators.end()) {
      operators.emplace_back(kinds);
    }
  }
  for (const std::string& op : operators) ++codes_by_operator_[op][code];
  for (const std::string& anomaly : anomalies) ++anomalies_[anomaly];
  std::vector<std::string>& said = messages_by_code_[code];
  const std::string message = outcome.message.substr(0, kMessageChars);
  if (!message.empty() && said.size() < kMessagesPerCode &&
      std::find(said.begin(), said.end(), message) == said.end()) {
    said.push_back(message);
  }
  latencies_ms_.push_back(outcome.ms);
}

void RpcStats::Merge(const RpcStats& other) {
  calls_ += other.calls_;
  messages_ += other.messages_;
  malformed_ += other.malformed_;
  unparsable_ += other.unparsable_;
  write_refused_ += other.write_refused_;
  answers_ += other.answers_;
  for (const auto& [code, n] : other.codes_) codes_[code] += n;
  for (const auto& [code, n] : other.rejection_codes_) rejection_codes_[code] += n;
  for (const auto& [shape, codes] : other.codes_by_shape_) {
    for (const auto& [code, n] : codes) codes_by_shape_[shape][code] += n;
  }
  for (const auto& [op, codes] : other.codes_by_operator_) {
    for (const auto& [code, n] : codes) codes_by_operator_[op][code] += n;
  }
  for (const auto& [anomaly, n] : other.anomalies_) anomalies_[anomaly] += n;
  for (const auto& [code, said] : other.messages_by_code_) {
    std::vector<std::string>& mine = messages_by_code_[code];
    for (const std::string& m : said) {
      if (mine.size() < kMessagesPerCode && std::find(mine.begin(), mine.end(), m) == mine.end()) {
        mine.push_back(m);
      }
    }
  }
  latencies_ms_.insert(latencies_ms_.end(), other.latencies_ms_.begin(), other.latencies_ms_.end());
}

int64_t RpcStats::deadline_exceeded() const {
  const auto it = codes_.find("DEADLINE_EXCEEDED");
  return it == codes_.end() ? 0 : it->second;
}

double RpcStats::QuantileMs(double q) const {
  if (latencies_ms_.empty()) return 0;
  std::vector<double> sorted = latencies_ms_;
  const size_t at = std::min(sorted.size() - 1, static_cast<size_t>(q * (sorted.size() - 1) + 0.5));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(at), sorted.end());
  return sorted[at];
}

std::string RpcStats::CodesSummary() const {
  std::vector<std::string> parts;
  for (const auto& [code, n] : ByCount(codes_)) parts.push_back(absl::StrCat(code, " ", n));
  return absl::StrJoin(parts, ", ");
}

nlohmann::json RpcStats::ToJson() const {
  return {{"calls", calls_},
          {"messages", messages_},
          {"malformed_messages", malformed_},
          {"unparsable_messages", unparsable_},
          {"calls_with_a_refused_write", write_refused_},
          {"answers", answers_},
          {"codes", codes_},
          {"rejections_in_answers", rejection_codes_},
          {"codes_by_shape", codes_by_shape_},
          {"codes_by_operator", codes_by_operator_},
          {"status_messages", messages_by_code_},
          {"anomalies", anomalies_},
          {"deadline_exceeded", deadline_exceeded()},
          {"latency_ms",
           {{"p50", QuantileMs(0.5)}, {"p90", QuantileMs(0.9)}, {"p99", QuantileMs(0.99)},
            {"max", QuantileMs(1.0)}}}};
}

std::string FileSafe(const std::string& name) {
  std::string safe = name;
  for (char& c : safe) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '.';
  }
  return safe;
}

void WriteCallFile(const std::string& path, const CallInput& input, const CallOutcome* outcome,
                   const nlohmann::json& extra) {
  nlohmann::json json = CallInputToJson(input);
  if (outcome != nullptr) {
    json["outcome"] = {{"code", CodeName(outcome->code)},
                       {"message", outcome->message},
                       {"answers", outcome->answers.size()},
                       {"ms", outcome->ms}};
  }
  for (const auto& [key, value] : extra.items()) json[key] = value;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << json.dump(1) << "\n";
  for (const Step& step : input.steps) {
    if (step.kind == StepKind::kWrite && step.malformed) {
      std::ofstream(path + ".bin", std::ios::binary) << step.bytes;
      break;
    }
  }
}

std::string SampleSaver::Save(const std::string& rpc, const std::string& anomaly,
                              const CallInput& input, const CallOutcome& outcome) {
  std::string path;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string>& kept = saved_[rpc][anomaly];
    if (static_cast<int>(kept.size()) >= per_kind_) return "";
    path = absl::StrCat(dir_, "/", FileSafe(rpc), "/", anomaly, "-", kept.size(), ".json");
    kept.push_back(path);
  }
  WriteCallFile(path, input, &outcome);
  return path;
}

nlohmann::json SampleSaver::Index() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return saved_;
}

void PrintTable(const std::vector<std::pair<std::string, RpcStats>>& rows, std::FILE* out) {
  std::fprintf(out, "%-34s %7s %8s %8s %9s %6s  %s\n", "RPC", "calls", "malformed", "p50 ms",
               "max ms", "DL", "codes");
  for (const auto& [name, stats] : rows) {
    std::fprintf(out, "%-34s %7lld %8lld %8.1f %9.1f %6lld  %s\n", name.c_str(),
                 static_cast<long long>(stats.calls()), static_cast<long long>(stats.malformed()),
                 stats.QuantileMs(0.5), stats.QuantileMs(1.0),
                 static_cast<long long>(stats.deadline_exceeded()), stats.CodesSummary().c_str());
  }
}

}  // namespace waymark::bench::hostile

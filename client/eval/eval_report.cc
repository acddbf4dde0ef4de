#include "client/eval/eval_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include "client/common/output.h"

namespace waymark::cli {
namespace {

// Most frequent predictions first, so the line reads as "where did this crossing's queries go";
// on ties crossings by name, then "not recognized".
std::vector<std::pair<std::string, int>> SortedPredictions(const std::map<std::string, int>& row) {
  std::vector<std::pair<std::string, int>> sorted(row.begin(), row.end());
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    const bool a_missed = a.first == kNotRecognized;
    const bool b_missed = b.first == kNotRecognized;
    return std::tie(b.second, a_missed, a.first) < std::tie(a.second, b_missed, b.first);
  });
  return sorted;
}

std::string OptionalCsv(const std::optional<double>& value) {
  return value.has_value() ? fmt::format("{:.3f}", *value) : "";
}

}  // namespace

nlohmann::json SummaryToJson(const EvalSummary& s) {
  nlohmann::json per_crossing = nlohmann::json::object();
  for (const auto& [name, recall] : s.per_crossing) {
    per_crossing[name] = {{"queries", recall.queries},
                          {"correct", recall.correct},
                          {"recall", static_cast<double>(recall.correct) / recall.queries}};
  }
  nlohmann::json confusion = nlohmann::json::object();
  for (const auto& [truth, row] : s.confusion) confusion[truth] = row;
  return {
      {"queries", s.queries},
      {"known_queries", s.known_queries},
      {"unknown_queries", s.unknown_queries},
      {"correct", s.correct},
      {"false_accepts", s.false_accepts},
      {"top1_accuracy", OptionalJson(s.top1_accuracy)},
      {"false_accept_rate", OptionalJson(s.false_accept_rate)},
      {"precision", OptionalJson(s.precision)},
      {"heading_queries", s.heading_queries},
      {"heading_error_deg_median", OptionalJson(s.heading_error_deg_median)},
      {"heading_error_deg_mean", OptionalJson(s.heading_error_deg_mean)},
      {"heading_error_deg_max", OptionalJson(s.heading_error_deg_max)},
      {"latency_ms_p50", OptionalJson(s.latency_ms_p50)},
      {"latency_ms_p99", OptionalJson(s.latency_ms_p99)},
      {"latency_ms_mean", OptionalJson(s.latency_ms_mean)},
      {"recall",
       {{"recognized_rate", OptionalJson(s.recognized_rate)},
        {"known_recognized", s.known_recognized},
        {"per_crossing", std::move(per_crossing)}}},
      {"confusion", std::move(confusion)},
  };
}

void PrintSummary(std::ostream& out, const EvalSummary& s) {
  out << fmt::format("queries              {} ({} of known crossings, {} unknown)\n", s.queries,
                     s.known_queries, s.unknown_queries);
  out << fmt::format("top-1 accuracy       {} ({}/{})\n", FormatPercent(s.top1_accuracy), s.correct,
                     s.known_queries);
  out << fmt::format("recognized (any)     {} ({}/{})\n", FormatPercent(s.recognized_rate),
                     s.known_recognized, s.known_queries);
  out << fmt::format("false accepts        {} ({}/{} unknown)\n",
                     FormatPercent(s.false_accept_rate), s.false_accepts, s.unknown_queries);
  out << fmt::format("precision            {}\n", FormatPercent(s.precision));
  out << fmt::format("heading error (deg)  median {}, mean {}, max {} over {} queries\n",
                     FormatNumber(s.heading_error_deg_median),
                     FormatNumber(s.heading_error_deg_mean), FormatNumber(s.heading_error_deg_max),
                     s.heading_queries);
  out << fmt::format("latency (ms)         p50 {}, p99 {}, mean {}\n",
                     FormatNumber(s.latency_ms_p50), FormatNumber(s.latency_ms_p99),
                     FormatNumber(s.latency_ms_mean));
  if (s.confusion.empty()) return;
  out << "\nconfusion (true crossing: predicted count, ...)\n";
  for (const auto& [truth, row] : s.confusion) {
    int total = 0;
    std::string line;
    for (const auto& [predicted, count] : SortedPredictions(row)) {
      total += count;
      line += fmt::format("{}{} {}", line.empty() ? "" : ", ", predicted, count);
    }
    out << fmt::format("  {} ({}): {}\n", truth, total, line);
  }
}

std::string CsvField(std::string_view field) {
  if (field.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(field);
  std::string quoted = "\"";
  for (char c : field) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

void WritePerQueryCsv(std::ostream& out, const std::vector<QueryRecord>& records) {
  out << "path,truth,true_heading_deg,recognized,predicted,predicted_heading_deg,correct,"
         "heading_error_deg,decision,keypoints,latency_ms,server_ms,reason\n";
  for (const QueryRecord& r : records) {
    const QueryOutcome& o = r.outcome;
    const bool correct = IsCorrect(o);
    std::optional<double> heading_error;
    if (correct && o.true_heading_deg.has_value() && !std::isnan(o.predicted_heading_deg)) {
      heading_error = CircularHeadingError(*o.true_heading_deg, o.predicted_heading_deg);
    }
    out << fmt::format("{},{},{},{},{},{},{},{},{:.4f},{},{:.3f},{:.3f},{}\n", CsvField(r.path),
                       CsvField(o.truth), OptionalCsv(o.true_heading_deg), o.recognized ? 1 : 0,
                       CsvField(o.recognized ? o.predicted : ""),
                       o.recognized ? fmt::format("{:.3f}", o.predicted_heading_deg) : "",
                       correct ? 1 : 0, OptionalCsv(heading_error), r.decision, r.keypoints,
                       o.latency_ms, r.server_ms, CsvField(r.reason));
  }
}

}  // namespace waymark::cli

#ifndef WAYMARK_CLIENT_EVAL_EVAL_REPORT_H_
#define WAYMARK_CLIENT_EVAL_EVAL_REPORT_H_

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "client/eval/eval_metrics.h"

namespace waymark::cli {

// One evaluated query with what the per-query CSV shows beyond the metrics' inputs.
struct QueryRecord {
  std::string path;
  QueryOutcome outcome;
  double decision = 0;
  int keypoints = 0;
  double server_ms = 0;
  std::string reason;  // why not recognized
};

// The --json document of `eval` (without the database name): counts, fractions in [0, 1] or null
// where not applicable, heading error, latency, recall per crossing and the confusion counts.
nlohmann::json SummaryToJson(const EvalSummary& summary);

// The human-readable report: metrics, then one confusion line per true crossing.
void PrintSummary(std::ostream& out, const EvalSummary& summary);

// RFC 4180 quoting: fields with a comma, quote or line break are quoted, quotes doubled.
std::string CsvField(std::string_view field);

// Header plus one row per query.
void WritePerQueryCsv(std::ostream& out, const std::vector<QueryRecord>& records);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_EVAL_REPORT_H_

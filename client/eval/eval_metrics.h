#ifndef WAYMARK_CLIENT_EVAL_EVAL_METRICS_H_
#define WAYMARK_CLIENT_EVAL_EVAL_METRICS_H_

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace waymark::cli {

// The evaluation protocol of DESIGN.md ("Crossing recognition"), as pure functions over per-query
// outcomes so that it can be checked without a server.

// Confusion column for queries that were not recognized.
inline constexpr char kNotRecognized[] = "(not recognized)";

// What happened to one query.
struct QueryOutcome {
  std::string truth;  // the query's folder: a crossing name, or "unknown" (not in the database)
  std::optional<double> true_heading_deg;
  bool recognized = false;
  std::string predicted;  // crossing name when recognized
  double predicted_heading_deg = 0;
  double latency_ms = 0;  // client-measured wall time of the RPC
};

bool IsUnknownQuery(const QueryOutcome& outcome);
// Recognized as the crossing of its folder (never true for unknown queries).
bool IsCorrect(const QueryOutcome& outcome);

// The q-th percentile (q in [0, 100]) with linear interpolation between closest ranks (numpy's
// default), so p50 of {1, 2} is 1.5. nullopt for no values.
std::optional<double> Percentile(std::vector<double> values, double q);

// Absolute angle between two headings in degrees, in [0, 180]: 350 vs 10 is 20.
double CircularHeadingError(double a_deg, double b_deg);

// truth -> predicted crossing (or kNotRecognized) -> count.
using Confusion = std::map<std::string, std::map<std::string, int>>;
Confusion BuildConfusion(const std::vector<QueryOutcome>& outcomes);

struct CrossingRecall {
  int queries = 0;
  int correct = 0;
};

// Fractions are in [0, 1]; nullopt where the denominator is empty.
struct EvalSummary {
  int queries = 0;
  int known_queries = 0;
  int unknown_queries = 0;
  int correct = 0;           // known queries recognized as their own crossing
  int known_recognized = 0;  // known queries recognized as any crossing
  int false_accepts = 0;     // unknown queries recognized

  std::optional<double> top1_accuracy;      // correct / known_queries
  std::optional<double> recognized_rate;    // known_recognized / known_queries
  std::optional<double> false_accept_rate;  // false_accepts / unknown_queries
  // correct / every accepted query (known or unknown): how far a "recognized" can be trusted.
  std::optional<double> precision;

  int heading_queries = 0;  // correct queries whose file name carries a heading
  std::optional<double> heading_error_deg_median;
  std::optional<double> heading_error_deg_mean;
  std::optional<double> heading_error_deg_max;

  std::optional<double> latency_ms_p50;
  std::optional<double> latency_ms_p99;
  std::optional<double> latency_ms_mean;

  std::map<std::string, CrossingRecall> per_crossing;  // known crossings only
  Confusion confusion;
};

EvalSummary Summarize(const std::vector<QueryOutcome>& outcomes);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_EVAL_METRICS_H_

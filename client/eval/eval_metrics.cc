#include "client/eval/eval_metrics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "client/datasets/image_folder.h"

namespace waymark::cli {
namespace {

std::optional<double> Ratio(int numerator, int denominator) {
  if (denominator == 0) return std::nullopt;
  return static_cast<double>(numerator) / denominator;
}

std::optional<double> Mean(const std::vector<double>& values) {
  if (values.empty()) return std::nullopt;
  return std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

std::optional<double> Max(const std::vector<double>& values) {
  if (values.empty()) return std::nullopt;
  return *std::max_element(values.begin(), values.end());
}

}  // namespace

bool IsUnknownQuery(const QueryOutcome& outcome) { return outcome.truth == kUnknownFolder; }

bool IsCorrect(const QueryOutcome& outcome) {
  return !IsUnknownQuery(outcome) && outcome.recognized && outcome.predicted == outcome.truth;
}

std::optional<double> Percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::nullopt;
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(q, 0.0, 100.0) / 100.0 * (values.size() - 1);
  const size_t lower = static_cast<size_t>(std::floor(rank));
  const size_t upper = std::min(lower + 1, values.size() - 1);
  return values[lower] + (rank - lower) * (values[upper] - values[lower]);
}

double CircularHeadingError(double a_deg, double b_deg) {
  const double diff = std::fmod(std::fabs(a_deg - b_deg), 360.0);
  return diff > 180.0 ? 360.0 - diff : diff;
}

Confusion BuildConfusion(const std::vector<QueryOutcome>& outcomes) {
  Confusion confusion;
  for (const QueryOutcome& outcome : outcomes) {
    ++confusion[outcome.truth][outcome.recognized ? outcome.predicted : kNotRecognized];
  }
  return confusion;
}

EvalSummary Summarize(const std::vector<QueryOutcome>& outcomes) {
  EvalSummary summary;
  std::vector<double> heading_errors;
  std::vector<double> latencies;
  int accepted = 0;
  for (const QueryOutcome& outcome : outcomes) {
    ++summary.queries;
    latencies.push_back(outcome.latency_ms);
    if (outcome.recognized) ++accepted;
    if (IsUnknownQuery(outcome)) {
      ++summary.unknown_queries;
      if (outcome.recognized) ++summary.false_accepts;
      continue;
    }
    ++summary.known_queries;
    CrossingRecall& recall = summary.per_crossing[outcome.truth];
    ++recall.queries;
    if (outcome.recognized) ++summary.known_recognized;
    if (!IsCorrect(outcome)) continue;
    ++summary.correct;
    ++recall.correct;
    // A view enrolled with no heading answers NaN: the crossing is right, its heading unknown.
    if (outcome.true_heading_deg.has_value() && !std::isnan(outcome.predicted_heading_deg)) {
      heading_errors.push_back(
          CircularHeadingError(*outcome.true_heading_deg, outcome.predicted_heading_deg));
    }
  }
  summary.top1_accuracy = Ratio(summary.correct, summary.known_queries);
  summary.recognized_rate = Ratio(summary.known_recognized, summary.known_queries);
  summary.false_accept_rate = Ratio(summary.false_accepts, summary.unknown_queries);
  summary.precision = Ratio(summary.correct, accepted);

  summary.heading_queries = static_cast<int>(heading_errors.size());
  summary.heading_error_deg_median = Percentile(heading_errors, 50);
  summary.heading_error_deg_mean = Mean(heading_errors);
  summary.heading_error_deg_max = Max(heading_errors);

  summary.latency_ms_p50 = Percentile(latencies, 50);
  summary.latency_ms_p99 = Percentile(latencies, 99);
  summary.latency_ms_mean = Mean(latencies);

  summary.confusion = BuildConfusion(outcomes);
  return summary;
}

}  // namespace waymark::cli

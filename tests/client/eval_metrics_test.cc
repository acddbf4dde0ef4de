#include "client/eval/eval_metrics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace waymark::cli {
namespace {

TEST(PercentileTest, InterpolatesBetweenRanks) {
  EXPECT_FALSE(Percentile({}, 50).has_value());
  EXPECT_DOUBLE_EQ(*Percentile({7}, 99), 7);
  EXPECT_DOUBLE_EQ(*Percentile({4, 1, 3, 2}, 50), 2.5);  // unsorted input
  EXPECT_DOUBLE_EQ(*Percentile({1, 2, 3, 4}, 0), 1);
  EXPECT_DOUBLE_EQ(*Percentile({1, 2, 3, 4}, 100), 4);
  std::vector<double> hundred;
  for (int i = 1; i <= 100; ++i) hundred.push_back(i);
  EXPECT_NEAR(*Percentile(hundred, 99), 99.01, 1e-9);
  EXPECT_NEAR(*Percentile(hundred, 50), 50.5, 1e-9);
}

TEST(CircularHeadingErrorTest, WrapsAroundNorth) {
  EXPECT_DOUBLE_EQ(CircularHeadingError(350, 10), 20);
  EXPECT_DOUBLE_EQ(CircularHeadingError(10, 350), 20);
  EXPECT_DOUBLE_EQ(CircularHeadingError(0, 180), 180);
  EXPECT_DOUBLE_EQ(CircularHeadingError(90, 90), 0);
  EXPECT_DOUBLE_EQ(CircularHeadingError(30, 60), 30);
  EXPECT_DOUBLE_EQ(CircularHeadingError(725, 0), 5);
  EXPECT_DOUBLE_EQ(CircularHeadingError(0, 270), 90);
}

QueryOutcome Outcome(std::string truth, bool recognized, std::string predicted,
                     std::optional<double> true_heading, double heading, double latency) {
  QueryOutcome o;
  o.truth = std::move(truth);
  o.recognized = recognized;
  o.predicted = std::move(predicted);
  o.true_heading_deg = true_heading;
  o.predicted_heading_deg = heading;
  o.latency_ms = latency;
  return o;
}

// 4 known queries of A and B, 2 unknown.
std::vector<QueryOutcome> HandMadeResults() {
  return {
      Outcome("A", true, "A", 0, 350, 10),                 // correct, heading error 10
      Outcome("A", true, "B", 90, 90, 20),                 // wrong crossing
      Outcome("A", false, "", std::nullopt, 0, 30),        // missed
      Outcome("B", true, "B", 180, 210, 40),               // correct, heading error 30
      Outcome("unknown", true, "A", std::nullopt, 0, 50),  // false accept
      Outcome("unknown", false, "", std::nullopt, 0, 60),  // correctly rejected
  };
}

TEST(SummarizeTest, CountsAccuracyAndFalseAccepts) {
  const EvalSummary s = Summarize(HandMadeResults());
  EXPECT_EQ(s.queries, 6);
  EXPECT_EQ(s.known_queries, 4);
  EXPECT_EQ(s.unknown_queries, 2);
  EXPECT_EQ(s.correct, 2);
  EXPECT_DOUBLE_EQ(*s.top1_accuracy, 0.5);
  EXPECT_DOUBLE_EQ(*s.recognized_rate, 0.75);
  EXPECT_EQ(s.false_accepts, 1);
  EXPECT_DOUBLE_EQ(*s.false_accept_rate, 0.5);
  EXPECT_DOUBLE_EQ(*s.precision, 2.0 / 4.0);  // 4 accepted, 2 right
}

TEST(SummarizeTest, HeadingErrorOnlyOverCorrectQueriesWithAHeading) {
  const EvalSummary s = Summarize(HandMadeResults());
  EXPECT_EQ(s.heading_queries, 2);
  EXPECT_DOUBLE_EQ(*s.heading_error_deg_median, 20);
  EXPECT_DOUBLE_EQ(*s.heading_error_deg_mean, 20);
  EXPECT_DOUBLE_EQ(*s.heading_error_deg_max, 30);
}

TEST(SummarizeTest, LatencyOverAllQueries) {
  const EvalSummary s = Summarize(HandMadeResults());
  EXPECT_DOUBLE_EQ(*s.latency_ms_p50, 35);
  EXPECT_NEAR(*s.latency_ms_p99, 59.5, 1e-9);
  EXPECT_DOUBLE_EQ(*s.latency_ms_mean, 35);
}

TEST(SummarizeTest, ConfusionAndPerCrossingRecall) {
  const EvalSummary s = Summarize(HandMadeResults());
  using Row = std::map<std::string, int>;
  EXPECT_EQ(s.confusion.at("A"), (Row{{"A", 1}, {"B", 1}, {kNotRecognized, 1}}));
  EXPECT_EQ(s.confusion.at("B"), (Row{{"B", 1}}));
  EXPECT_EQ(s.confusion.at("unknown"), (Row{{"A", 1}, {kNotRecognized, 1}}));
  EXPECT_EQ(s.per_crossing.at("A").queries, 3);
  EXPECT_EQ(s.per_crossing.at("A").correct, 1);
  EXPECT_EQ(s.per_crossing.at("B").correct, 1);
  EXPECT_EQ(s.per_crossing.count("unknown"), 0u);
}

TEST(SummarizeTest, NotApplicableMetricsAreEmpty) {
  const EvalSummary no_unknown = Summarize({Outcome("A", true, "A", std::nullopt, 0, 5)});
  EXPECT_FALSE(no_unknown.false_accept_rate.has_value());
  EXPECT_FALSE(no_unknown.heading_error_deg_median.has_value());
  EXPECT_DOUBLE_EQ(*no_unknown.top1_accuracy, 1.0);

  const EvalSummary only_unknown = Summarize({Outcome("unknown", false, "", std::nullopt, 0, 5)});
  EXPECT_FALSE(only_unknown.top1_accuracy.has_value());
  EXPECT_FALSE(only_unknown.precision.has_value());
  EXPECT_DOUBLE_EQ(*only_unknown.false_accept_rate, 0.0);

  const EvalSummary nothing = Summarize({});
  EXPECT_EQ(nothing.queries, 0);
  EXPECT_FALSE(nothing.latency_ms_p50.has_value());
}

TEST(IsCorrectTest, NeedsRecognitionAndTheRightName) {
  EXPECT_TRUE(IsCorrect(Outcome("A", true, "A", std::nullopt, 0, 0)));
  EXPECT_FALSE(IsCorrect(Outcome("A", false, "A", std::nullopt, 0, 0)));
  EXPECT_FALSE(IsCorrect(Outcome("A", true, "a", std::nullopt, 0, 0)));
  EXPECT_FALSE(IsCorrect(Outcome("unknown", true, "unknown", std::nullopt, 0, 0)));
}

}  // namespace
}  // namespace waymark::cli

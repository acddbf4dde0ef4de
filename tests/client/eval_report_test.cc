#include "client/eval/eval_report.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;

QueryRecord Record(std::string path, std::string truth, bool recognized, std::string predicted,
                   std::optional<double> true_heading, double heading) {
  QueryRecord r;
  r.path = std::move(path);
  r.outcome.truth = std::move(truth);
  r.outcome.recognized = recognized;
  r.outcome.predicted = std::move(predicted);
  r.outcome.true_heading_deg = true_heading;
  r.outcome.predicted_heading_deg = heading;
  r.outcome.latency_ms = 12.5;
  return r;
}

TEST(SummaryToJsonTest, HasTheDocumentedKeysWithNullWhereNotApplicable) {
  QueryOutcome correct;
  correct.truth = "A";
  correct.recognized = true;
  correct.predicted = "A";
  correct.latency_ms = 4;
  const nlohmann::json json = SummaryToJson(Summarize({correct}));
  for (const char* key :
       {"queries", "known_queries", "unknown_queries", "top1_accuracy", "false_accept_rate",
        "heading_error_deg_median", "latency_ms_p50", "latency_ms_p99", "recall", "confusion"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
  EXPECT_EQ(json["queries"], 1);
  EXPECT_DOUBLE_EQ(json["top1_accuracy"].get<double>(), 1.0);
  EXPECT_TRUE(json["false_accept_rate"].is_null());  // no unknown folder
  EXPECT_TRUE(json["heading_error_deg_median"].is_null());
  EXPECT_DOUBLE_EQ(json["latency_ms_p50"].get<double>(), 4);
  EXPECT_EQ(json["confusion"]["A"]["A"], 1);
  EXPECT_DOUBLE_EQ(json["recall"]["per_crossing"]["A"]["recall"].get<double>(), 1.0);
}

TEST(PrintSummaryTest, ShowsMetricsAndConfusionLines) {
  std::vector<QueryOutcome> outcomes;
  for (const QueryRecord& r :
       {Record("a", "A", true, "A", 0, 10), Record("b", "A", false, "", std::nullopt, 0),
        Record("c", "unknown", true, "B", std::nullopt, 0)}) {
    outcomes.push_back(r.outcome);
  }
  std::ostringstream out;
  PrintSummary(out, Summarize(outcomes));
  EXPECT_THAT(out.str(), HasSubstr("top-1 accuracy       50.0% (1/2)"));
  EXPECT_THAT(out.str(), HasSubstr("false accepts        100.0% (1/1 unknown)"));
  EXPECT_THAT(out.str(), HasSubstr("A (2): A 1, (not recognized) 1"));
  EXPECT_THAT(out.str(), HasSubstr("unknown (1): B 1"));
}

TEST(CsvFieldTest, QuotesOnlyWhenNeeded) {
  EXPECT_EQ(CsvField("plain"), "plain");
  EXPECT_EQ(CsvField("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvField("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(CsvField("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(CsvField(""), "");
}

TEST(WritePerQueryCsvTest, OneRowPerQueryWithHeadingError) {
  std::ostringstream out;
  WritePerQueryCsv(out, {Record("q/A/350.png", "A", true, "A", 350, 10),
                         Record("q/unknown/x,y.png", "unknown", false, "", std::nullopt, 0)});
  std::istringstream lines(out.str());
  std::string header, first, second, extra;
  std::getline(lines, header);
  std::getline(lines, first);
  std::getline(lines, second);
  EXPECT_FALSE(std::getline(lines, extra));
  EXPECT_THAT(header, HasSubstr("path,truth,true_heading_deg,recognized,predicted"));
  EXPECT_THAT(first, HasSubstr("q/A/350.png,A,350.000,1,A,10.000,1,20.000,"));
  EXPECT_THAT(second, HasSubstr("\"q/unknown/x,y.png\",unknown,,0,,,0,,"));
}

}  // namespace
}  // namespace waymark::cli

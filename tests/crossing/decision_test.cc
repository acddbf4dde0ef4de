#include "server/crossing/decision.h"

#include <cmath>

#include <gtest/gtest.h>

namespace waymark::crossing {
namespace {

// The paper prints Des truncated to two decimals.
double Truncate2(double v) { return std::floor(v * 100 + 1e-9) / 100; }

struct TableCase {
  const char* name;
  std::vector<double> m;
  std::vector<double> s;
  std::vector<double> printed;
  std::vector<double> computed;  // METHODS.md's column (itself truncated to 3 decimals)
};

class PaperTableTest : public testing::TestWithParam<TableCase> {};

TEST_P(PaperTableTest, ReproducesPrintedDecisionValues) {
  const TableCase& c = GetParam();
  const std::vector<double> des = DecisionValues(c.m, c.s, 0.5, 0.5);
  ASSERT_EQ(des.size(), c.printed.size());
  for (size_t i = 0; i < des.size(); ++i) {
    EXPECT_NEAR(des[i], c.computed[i], 1e-3) << c.name << " row " << i;
    EXPECT_NEAR(Truncate2(des[i]), c.printed[i], 1e-9) << c.name << " row " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(
    MethodsTables, PaperTableTest,
    testing::Values(
        TableCase{"Table4_Fig5c", {81, 79, 60}, {0.76, 0.84, 0.72}, {0.95, 0.98, 0.79},
                  {0.952, 0.988, 0.799}},
        TableCase{"Table4_Fig5d", {16, 15, 9}, {0.50, 0.52, 0.51}, {0.98, 0.96, 0.77},
                  {0.981, 0.969, 0.771}},
        TableCase{"Table8_Fig8d", {5, 5, 5}, {0.63, 0.61, 0.74}, {0.92, 0.91, 1.0},
                  {0.926, 0.912, 1.000}}),
    [](const testing::TestParamInfo<TableCase>& info) { return std::string(info.param.name); });

TEST(DecisionTest, WinnerOfTheTablesIsThePapersAnswer) {
  // Fig 5(c): view 1-6 wins over 1-5 although it has fewer matches (hue decides).
  EXPECT_EQ(ArgMax(DecisionValues({81, 79, 60}, {0.76, 0.84, 0.72}, 0.5, 0.5)), 1);
  // Fig 8(d): all have 5 matches; 3-11 wins on hue.
  EXPECT_EQ(ArgMax(DecisionValues({5, 5, 5}, {0.63, 0.61, 0.74}, 0.5, 0.5)), 2);
}

TEST(DecisionTest, WeightsShiftTheDecision) {
  // Pure matches (alpha = 1): the most matches win.
  EXPECT_EQ(ArgMax(DecisionValues({81, 79, 60}, {0.76, 0.84, 0.72}, 1.0, 0.0)), 0);
  // Pure hue (beta = 1).
  EXPECT_EQ(ArgMax(DecisionValues({81, 79, 60}, {0.76, 0.84, 0.72}, 0.0, 1.0)), 1);
}

TEST(DecisionTest, ZeroSimilarityLeavesMatchesToDecide) {
  const auto des = DecisionValues({10, 20}, {0.0, 0.0}, 0.5, 0.5);
  EXPECT_DOUBLE_EQ(des[0], 0.25);
  EXPECT_DOUBLE_EQ(des[1], 0.5);
}

TEST(DecisionTest, ArgMaxTakesFirstOnTiesAndMinusOneWhenEmpty) {
  EXPECT_EQ(ArgMax({0.5, 0.7, 0.7}), 1);
  EXPECT_EQ(ArgMax({}), -1);
}

TEST(ClusteringRuleTest, JoinsBestCentreAtThreshold) {
  EXPECT_EQ(AssignCluster({3, 7, 5}, 5), 1);
  EXPECT_EQ(AssignCluster({5, 2}, 5), 0);   // exactly the threshold joins
  EXPECT_EQ(AssignCluster({4, 4, 1}, 5), -1);  // below: a new centre
  EXPECT_EQ(AssignCluster({6, 6}, 5), 0);   // ties: the older cluster
  EXPECT_EQ(AssignCluster({}, 5), -1);      // first view: the first centre
}

}  // namespace
}  // namespace waymark::crossing

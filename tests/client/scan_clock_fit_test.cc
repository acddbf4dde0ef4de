// Relations onto a log with regenerated stamps (client/eval/scan_clock_fit.h): a synthetic run whose
// laser ran at a steady 0.44 s, relations named by the original clock, odometry with a little
// noise; the fit must find the clock and put every relation on the scan it named.
#include "client/eval/scan_clock_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace waymark::cli {
namespace {

constexpr double kPeriod = 0.4392;   // s per scan of the original clock
constexpr double kOffset = 18.3;     // the scan taken at the relations' first stamp
constexpr double kT0 = 1031745833.448;

struct SyntheticRun {
  std::vector<Pose2> truth;
  std::vector<Pose2> odometry;
  std::vector<Relation> relations;
  std::vector<std::pair<int, int>> scans;  // the scans each relation names
};

// A robot driving at 0.25 m/s with turns of changing sign and length (so that the clock is pinned
// by turns, as on a real run), odometry from the true steps with 1 % / 0.5 deg noise.
SyntheticRun MakeRun(int scans) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  SyntheticRun run;
  Pose2 truth{0, 0, 0}, odom{0, 0, 0};
  for (int i = 0; i < scans; ++i) {
    run.truth.push_back(truth);
    run.odometry.push_back(odom);
    const double turn = 0.08 * std::sin(i / 37.0) * std::sin(i / 11.0);
    const Pose2 step{0.11, 0.0, turn};
    truth = Compose(truth, step);
    const Pose2 measured{step.x * (1.0 + 0.01 * noise(rng)), 0.002 * noise(rng),
                         step.theta + 0.009 * noise(rng)};
    odom = Compose(odom, measured);
  }
  // Relations 4 scans apart from the first scan the clock names, and a few long ones.
  auto stamp_of = [](int scan) { return kT0 + (scan - kOffset) * kPeriod + 0.001; };
  const int first = static_cast<int>(std::ceil(kOffset));
  for (int i = first; i + 4 < scans; i += 4) run.scans.push_back({i, i + 4});
  for (int i = first; i + 400 < scans; i += 97) run.scans.push_back({i, i + 400});
  for (auto [a, b] : run.scans) {
    run.relations.push_back({stamp_of(a), stamp_of(b), Compose(Inverse(run.truth[a]), run.truth[b])});
  }
  return run;
}

TEST(ScanClockFitTest, FindsTheClockAndPutsEveryRelationOnItsScan) {
  const SyntheticRun run = MakeRun(3000);
  absl::StatusOr<ScanClockFit> fit = FitScanClock(run.odometry, run.relations);
  ASSERT_TRUE(fit.ok()) << fit.status();
  // Off by less than one scan over the whole run, at its start and at its end.
  EXPECT_NEAR(fit->offset, kOffset, 1.0);
  EXPECT_LT(std::abs(fit->period - kPeriod) * 3000 / kPeriod, 1.0);
  EXPECT_GT(fit->cost_minus_one, fit->cost);
  EXPECT_GT(fit->cost_plus_one, fit->cost);
  int right = 0;
  for (size_t k = 0; k < run.relations.size(); ++k) {
    right += fit->IndexOf(run.relations[k].t1, 3000) == run.scans[k].first &&
             fit->IndexOf(run.relations[k].t2, 3000) == run.scans[k].second;
  }
  EXPECT_EQ(right, static_cast<int>(run.relations.size()));

  // Restamped onto a uniform 0.9 s clock (as MOLA regenerated Killian's), they name those scans.
  std::vector<double> stamps;
  for (int i = 0; i < 3000; ++i) stamps.push_back(1705905558.98 + 0.9 * i);
  std::vector<Relation> outside = run.relations;
  outside.push_back({kT0 + 5000 * kPeriod, kT0 + 5004 * kPeriod, Pose2{}});  // past the log's end
  int dropped = 0;
  const std::vector<Relation> moved = RestampRelations(outside, *fit, stamps, &dropped);
  EXPECT_EQ(dropped, 1);
  ASSERT_EQ(moved.size(), run.relations.size());
  EXPECT_DOUBLE_EQ(moved.front().t1, stamps[run.scans.front().first]);
  EXPECT_DOUBLE_EQ(moved.back().t2, stamps[run.scans.back().second]);
}

TEST(ScanClockFitTest, RefusesWhatItCannotFit) {
  EXPECT_FALSE(FitScanClock({Pose2{}}, {{0, 1, Pose2{}}}).ok());
  const SyntheticRun run = MakeRun(100);
  std::vector<Relation> only_long = {{kT0, kT0 + 30, Pose2{}}};
  EXPECT_FALSE(FitScanClock(run.odometry, only_long).ok());
}

}  // namespace
}  // namespace waymark::cli

#include "server/visual_slam/geometry/sequential_sampler.h"

#include <gtest/gtest.h>

#include <limits>
#include <numeric>
#include <optional>
#include <vector>

#include "server/visual_slam/geometry/essential_solver.h"
#include "server/visual_slam/geometry/pnp_solver.h"
#include "tests/visual_slam/synthetic_two_view.h"

namespace waymark::visual_slam {
namespace {

using testing::AllIndices;
using testing::kFocal;
using testing::MakeMotion;
using testing::Scene;
using testing::SceneMaker;

struct InlierQuality {
  int true_found = 0;  // true inliers in the found set
  int true_total = 0;  // true inliers in the scene
  int outliers = 0;    // outliers in the found set
  int found = 0;
};

InlierQuality Quality(const Scene& s, const std::vector<int>& found) {
  InlierQuality q;
  for (bool b : s.inlier) q.true_total += b;
  for (int i : found) (s.inlier[i] ? q.true_found : q.outliers) += 1;
  q.found = static_cast<int>(found.size());
  return q;
}

// ~200 pairs, 40 % outliers, 0.5 px noise: the sampler finds the motion's inlier set and the
// essential matrix over it gives the motion back.
class SequentialSampleSeeds : public ::testing::TestWithParam<uint32_t> {};

TEST_P(SequentialSampleSeeds, EssentialRecoversKnownMotion) {
  const Motion truth = MakeMotion(2, -4, 1.5, Eigen::Vector3d(0.3, 0.05, 0.1));
  SceneMaker maker(GetParam());
  const Scene s = maker.Make(200, 0.4, 0.5, truth);
  EssentialSolver solver(s.c, kFocal);
  const std::vector<int> candidates = AllIndices(200);
  const SamplerResult r = SequentialSample(solver, candidates, std::vector<double>(200, 0.5),
                                           std::nullopt, 2.0, SamplerOptions());
  ASSERT_GE(r.chosen, 0);
  EXPECT_EQ(r.chosen, 0);  // no prediction: M1
  EXPECT_GE(r.rounds, 1);
  EXPECT_GT(r.hypotheses, 0);
  ASSERT_EQ(r.eta.size(), 200u);
  const std::vector<int>& inliers = r.best[r.chosen].inliers;
  const InlierQuality q = Quality(s, inliers);
  EXPECT_GE(q.true_found, 0.95 * q.true_total) << q.true_found << " of " << q.true_total;
  EXPECT_LT(q.outliers, 0.02 * q.found) << q.outliers << " outliers of " << q.found;

  const absl::StatusOr<Motion> m = EssentialFromInliers(s.c, inliers);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, truth.R), 0.5);
  EXPECT_LT(testing::DirectionErrorDeg(m->t, truth.t), 1.0);
  EXPECT_NEAR(m->t.norm(), 1.0, 1e-9);
  // The final eta ranks the true inliers above the outliers on average.
  double eta_in = 0, eta_out = 0;
  for (int i = 0; i < 200; ++i) (s.inlier[i] ? eta_in : eta_out) += r.eta[i];
  EXPECT_GT(eta_in / q.true_total, eta_out / (200 - q.true_total));
}

TEST_P(SequentialSampleSeeds, PnpRecoversKnownMotion) {
  const Motion truth = MakeMotion(-3, 5, 2, Eigen::Vector3d(-0.2, 0.08, 0.15));
  SceneMaker maker(GetParam() + 100);
  const Scene s = maker.Make(200, 0.4, 0.5, truth);
  PnpSolver solver(s.c, kFocal);
  const SamplerResult r = SequentialSample(solver, AllIndices(200), std::vector<double>(200, 0.5),
                                           std::nullopt, 2.0, SamplerOptions());
  ASSERT_GE(r.chosen, 0);
  const std::vector<int>& inliers = r.best[r.chosen].inliers;
  const InlierQuality q = Quality(s, inliers);
  EXPECT_GE(q.true_found, 0.95 * q.true_total) << q.true_found << " of " << q.true_total;
  EXPECT_LT(q.outliers, 0.02 * q.found) << q.outliers << " outliers of " << q.found;

  const absl::StatusOr<Motion> m = RefinePnp(s.c, inliers, r.best[r.chosen].motion, kFocal);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_LT(testing::RotationErrorDeg(m->R, truth.R), 0.2);
  EXPECT_LT((m->t - truth.t).norm(), 0.01);
}

// Three different scenes (the scene generator's seed), so that a pass is not one lucky draw.
INSTANTIATE_TEST_SUITE_P(Scenes, SequentialSampleSeeds, ::testing::Values(7u, 8u, 9u));

TEST(SequentialSample, SameSeedSameResult) {
  const Motion truth = MakeMotion(1, 2, 3, Eigen::Vector3d(0.1, 0, 0.05));
  SceneMaker maker(3);
  const Scene s = maker.Make(120, 0.3, 0.5, truth);
  PnpSolver solver(s.c, kFocal);
  const auto run = [&] {
    return SequentialSample(solver, AllIndices(120), std::vector<double>(120, 0.5), std::nullopt,
                            2.0, SamplerOptions());
  };
  const SamplerResult a = run(), b = run();
  ASSERT_EQ(a.best.size(), b.best.size());
  for (size_t k = 0; k < a.best.size(); ++k) EXPECT_EQ(a.best[k].inliers, b.best[k].inliers);
  EXPECT_EQ(a.eta, b.eta);
  EXPECT_EQ(a.rounds, b.rounds);
  EXPECT_EQ(a.hypotheses, b.hypotheses);
}

// Two rigid motions of similar support (the static background and an object moving with the
// camera's view, e.g. a person walking): eq 12 picks the one closer to the predicted motion.
class TieBreak : public ::testing::Test {
 protected:
  void SetUp() override {
    a_ = MakeMotion(0, 2, 0, Eigen::Vector3d(0.1, 0, 0.05));
    // Different epipolar geometry too (A sideways, B up and forward): a monocular camera cannot
    // tell two motions apart whose epipolar lines coincide.
    b_ = MakeMotion(0, -3, 1, Eigen::Vector3d(0.0, -0.2, 0.1));
    SceneMaker maker(21);
    for (int i = 0; i < 100; ++i) {  // interleaved: 100 pairs of A, 90 of B, 20 outliers
      const Eigen::Vector3d Xa = maker.VisiblePoint(a_);
      c_.push_back(maker.Pair(Xa, a_, 0.5));
      group_.push_back(0);
      if (i < 90) {
        const Eigen::Vector3d Xb = maker.VisiblePoint(b_);
        c_.push_back(maker.Pair(Xb, b_, 0.5));
        group_.push_back(1);
      }
      if (i < 20) {
        c_.push_back(maker.Outlier(maker.VisiblePoint(a_)));
        group_.push_back(2);
      }
    }
  }

  // Fraction of `inliers` in `group`.
  double Purity(const std::vector<int>& inliers, int group) const {
    int in = 0;
    for (int i : inliers) in += group_[i] == group;
    return inliers.empty() ? 0 : static_cast<double>(in) / inliers.size();
  }

  Motion a_, b_;
  std::vector<Correspondence> c_;
  std::vector<int> group_;
};

TEST_F(TieBreak, PnpPicksTheMotionNearestThePrediction) {
  PnpSolver solver(c_, kFocal);
  const int n = static_cast<int>(c_.size());
  Motion near_a = a_, near_b = b_;
  near_a.t += Eigen::Vector3d(0.01, -0.01, 0.005);
  near_b.t += Eigen::Vector3d(-0.01, 0.01, 0.0);
  const SamplerResult ra = SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5),
                                            near_a, 2.0, SamplerOptions());
  const SamplerResult rb = SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5),
                                            near_b, 2.0, SamplerOptions());
  ASSERT_GE(ra.chosen, 0);
  ASSERT_GE(rb.chosen, 0);
  ASSERT_GE(ra.best.size(), 2u);
  EXPECT_GT(Purity(ra.best[ra.chosen].inliers, 0), 0.95);
  EXPECT_GT(Purity(rb.best[rb.chosen].inliers, 1), 0.95);
  EXPECT_LT(testing::RotationErrorDeg(ra.best[ra.chosen].motion.R, a_.R), 1.0);
  EXPECT_LT(testing::RotationErrorDeg(rb.best[rb.chosen].motion.R, b_.R), 1.0);
  // Without a prediction, the larger group (A) wins as M1.
  const SamplerResult none = SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5),
                                              std::nullopt, 2.0, SamplerOptions());
  ASSERT_EQ(none.chosen, 0);
  EXPECT_GT(Purity(none.best[0].inliers, 0), 0.95);
}

// A solver with two known motions: a sample all of group 0 gives motion A, all of group 1 gives
// B, anything else no model; a pair fits only its own group's motion. Translations are unit
// directions, as from the essential matrix.
class TwoMotionSolver : public MotionSolver {
 public:
  TwoMotionSolver(std::vector<int> group, Motion a, Motion b)
      : group_(std::move(group)), motions_{a, b} {}
  int SampleSize() const override { return 2; }
  std::vector<Motion> Solve(const std::vector<int>& sample) const override {
    const int g = group_[sample[0]];
    for (int i : sample)
      if (group_[i] != g) return {};
    return {motions_[g]};
  }
  double ErrorPx(const Motion& motion, int i) const override {
    const int g = group_[i];
    return (motion.t - motions_[g].t).norm() < 1e-12 ? 0.0
                                                     : std::numeric_limits<double>::infinity();
  }
  bool UnitTranslation() const override { return true; }

 private:
  std::vector<int> group_;
  Motion motions_[2];
};

TEST(TieBreakUnitTranslation, ComparesTranslationDirectionsOnly) {
  const Motion a = MakeMotion(0, 1, 0, Eigen::Vector3d(1, 0, 0));
  const Motion b = MakeMotion(0, 1, 0, Eigen::Vector3d(0, 0.6, 0.8));  // same rotation
  std::vector<int> group;
  for (int i = 0; i < 40; ++i) group.push_back(i < 21 ? 0 : 1);  // 21 A, 19 B
  TwoMotionSolver solver(group, a, b);
  const std::vector<int> candidates = AllIndices(40);
  const std::vector<double> eta(40, 0.5);
  // Metric predictions: (3, 0, 0) points like A; (0, 0.06, 0.08) like B although |t_B - (0, 0.06,
  // 0.08)| = 0.9 > |t_A - (0, 0.06, 0.08)| would favour A without normalization.
  Motion near_a = a, near_b = b;
  near_a.t = Eigen::Vector3d(3, 0, 0);
  near_b.t = Eigen::Vector3d(0, 0.06, 0.08);
  const SamplerResult ra = SequentialSample(solver, candidates, eta, near_a, 2.0, SamplerOptions());
  const SamplerResult rb = SequentialSample(solver, candidates, eta, near_b, 2.0, SamplerOptions());
  ASSERT_EQ(ra.best.size(), 2u);
  ASSERT_EQ(rb.best.size(), 2u);
  EXPECT_EQ(ra.best[0].inliers.size(), 21u);  // M1 = A (more inliers)
  EXPECT_EQ(ra.best[1].inliers.size(), 19u);
  EXPECT_EQ(ra.chosen, 0);
  EXPECT_EQ(rb.chosen, 1);
}

TEST_F(TieBreak, EssentialTwoGroupsWithoutOutliers) {
  // Monocular: 8-pair samples pure in one group are rare when two groups share the candidates, so
  // this scene has no outliers.
  std::vector<Correspondence> c;
  std::vector<int> group;
  for (size_t i = 0; i < c_.size(); ++i) {
    if (group_[i] == 2) continue;
    c.push_back(c_[i]);
    group.push_back(group_[i]);
  }
  group_ = group;
  EssentialSolver solver(c, kFocal);
  const int n = static_cast<int>(c.size());
  Motion near_a = a_, near_b = b_;
  near_a.t *= 3;
  near_b.t *= 0.2;
  const SamplerResult ra = SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5),
                                            near_a, 2.0, SamplerOptions());
  const SamplerResult rb = SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5),
                                            near_b, 2.0, SamplerOptions());
  ASSERT_GE(ra.chosen, 0);
  ASSERT_GE(rb.chosen, 0);
  EXPECT_GT(Purity(ra.best[ra.chosen].inliers, 0), 0.9);
  EXPECT_GT(Purity(rb.best[rb.chosen].inliers, 1), 0.9);
}

TEST_F(TieBreak, FarSmallerHypothesisNeverWinsOnMotionAlone) {
  PnpSolver solver(c_, kFocal);
  const int n = static_cast<int>(c_.size());
  SamplerOptions options;
  options.tie_break_fraction = 0.95;  // B has 90 % of A's support: not enough
  const SamplerResult r =
      SequentialSample(solver, AllIndices(n), std::vector<double>(n, 0.5), b_, 2.0, options);
  ASSERT_EQ(r.chosen, 0);
  EXPECT_GT(Purity(r.best[0].inliers, 0), 0.95);
}

// eq 10 on a hand case: positions 0..5, I* = {0, 1, 2}, I = {1, 2, 3, 4}.
TEST(UpdateEta, FourRulesAndClamping) {
  std::vector<double> eta = {0.5, 0.5, 0.95, 0.5, 0.01, 0.5};
  UpdateEta({0, 1, 2}, {1, 2, 3, 4}, 0.1, 0.02, &eta);
  EXPECT_DOUBLE_EQ(eta[0], 0.4);   // in I* only: -b1
  EXPECT_DOUBLE_EQ(eta[1], 0.6);   // in both: +b1
  EXPECT_DOUBLE_EQ(eta[2], 1.0);   // in both: +b1, clamped at 1
  EXPECT_DOUBLE_EQ(eta[3], 0.52);  // in I only: +b2
  EXPECT_DOUBLE_EQ(eta[4], 0.03);  // in I only: +b2
  EXPECT_DOUBLE_EQ(eta[5], 0.5);   // in neither: unchanged
  std::vector<double> low = {0.05};
  UpdateEta({0}, {}, 0.1, 0.02, &low);
  EXPECT_DOUBLE_EQ(low[0], 0.0);  // clamped at 0
}

Hypothesis H(std::vector<int> inliers, double tx = 0) {
  Hypothesis h;
  h.motion.t.x() = tx;
  h.inliers = std::move(inliers);
  return h;
}

std::vector<int> Range(int from, int to) {
  std::vector<int> v;
  for (int i = from; i < to; ++i) v.push_back(i);
  return v;
}

TEST(KeepHypothesis, KeepsThreeDistinctMostInliersFirst) {
  std::vector<Hypothesis> best;
  EXPECT_TRUE(KeepHypothesis(H(Range(0, 10), 1), &best));     // A: 10
  EXPECT_TRUE(KeepHypothesis(H(Range(100, 120), 2), &best));  // B: 20 enters at M1, A shifts down
  ASSERT_EQ(best.size(), 2u);
  EXPECT_EQ(best[0].motion.t.x(), 2);
  EXPECT_EQ(best[1].motion.t.x(), 1);
  EXPECT_FALSE(KeepHypothesis(H(Range(0, 10), 9), &best));    // same inlier set as A: not twice
  EXPECT_FALSE(KeepHypothesis(H(Range(0, 8), 9), &best));     // A again, fewer inliers
  EXPECT_TRUE(KeepHypothesis(H(Range(200, 215), 3), &best));  // C: 15, between B and A
  EXPECT_TRUE(KeepHypothesis(H(Range(300, 330), 4), &best));  // D: 30 enters at M1, A dropped
  ASSERT_EQ(best.size(), 3u);
  EXPECT_EQ(best[0].motion.t.x(), 4);
  EXPECT_EQ(best[1].motion.t.x(), 2);
  EXPECT_EQ(best[2].motion.t.x(), 3);
  EXPECT_FALSE(KeepHypothesis(H(Range(400, 412), 5), &best));  // 12 < M3's 15
  // A better version of C (overlapping more than half of C) replaces it and moves up.
  EXPECT_TRUE(KeepHypothesis(H(Range(205, 230), 6), &best));
  ASSERT_EQ(best.size(), 3u);
  EXPECT_EQ(best[0].motion.t.x(), 4);
  EXPECT_EQ(best[1].motion.t.x(), 6);
  EXPECT_EQ(best[2].motion.t.x(), 2);
  EXPECT_FALSE(KeepHypothesis(H({}, 7), &best));  // no inliers: never kept
}

TEST(ReferenceHypothesis, TheKeptHypothesisHoldingMostOfTheSample) {
  const std::vector<Hypothesis> best = {H(Range(0, 20)), H(Range(15, 30)), H(Range(50, 60))};
  EXPECT_EQ(ReferenceHypothesis(best, {1, 2, 3}), 0);
  EXPECT_EQ(ReferenceHypothesis(best, {25, 2, 27}), 1);   // 2 of 3 in M2
  EXPECT_EQ(ReferenceHypothesis(best, {16, 17, 18}), 0);  // in M1 and M2: the better-ranked
  EXPECT_EQ(ReferenceHypothesis(best, {1, 40, 41}), -1);  // no hypothesis holds half of it
  EXPECT_EQ(ReferenceHypothesis({}, {1, 2, 3}), -1);
}

TEST(MotionDifference, AngleAndTranslation) {
  const Motion a = MakeMotion(0, 0, 0, Eigen::Vector3d(0, 0, 0));
  const Motion b = MakeMotion(0, 0, 30, Eigen::Vector3d(3, 4, 0));
  EXPECT_NEAR(MotionDifference(a, b, 1.0, 1.0), testing::kPi / 6 + 5, 1e-9);
  EXPECT_NEAR(MotionDifference(a, b, 2.0, 0.5), testing::kPi / 3 + 2.5, 1e-9);
  EXPECT_NEAR(MotionDifference(b, b, 1.0, 1.0), 0, 1e-6);
}

TEST(SequentialSample, TooFewOrNoSamplableCandidates) {
  const Motion truth = MakeMotion(1, 1, 1, Eigen::Vector3d(0.1, 0, 0));
  SceneMaker maker(5);
  Scene s = maker.Make(30, 0.0, 0.0, truth);
  EssentialSolver essential(s.c, kFocal);
  ASSERT_EQ(essential.SampleSize(), 5);
  SamplerResult r =
      SequentialSample(essential, {0, 1, 2, 3}, {}, std::nullopt, 2.0, SamplerOptions());
  EXPECT_EQ(r.chosen, -1);
  EXPECT_TRUE(r.best.empty());
  EXPECT_EQ(r.eta.size(), 4u);
  r = SequentialSample(essential, {}, {}, std::nullopt, 2.0, SamplerOptions());
  EXPECT_EQ(r.chosen, -1);

  for (Correspondence& c : s.c) c.reference_point.reset();  // monocular pairs: PnP cannot sample
  PnpSolver pnp(s.c, kFocal);
  r = SequentialSample(pnp, AllIndices(30), std::vector<double>(30, 0.5), std::nullopt, 2.0,
                       SamplerOptions());
  EXPECT_EQ(r.chosen, -1);
  EXPECT_TRUE(r.best.empty());
  EXPECT_EQ(r.hypotheses, 0);
  // Out-of-range candidates are never sampled or counted.
  r = SequentialSample(pnp, {-1, 1000, 5}, {0.5, 0.5, 0.5}, std::nullopt, 2.0, SamplerOptions());
  EXPECT_EQ(r.chosen, -1);
}

TEST(SequentialSample, ZeroTranslationGivesNoEssentialHypothesis) {
  // Pure rotation: no sample of 5 shows any rotation-compensated parallax (EssentialSolver::Solve).
  const Motion rotation = MakeMotion(2, 3, 1, Eigen::Vector3d::Zero());
  SceneMaker maker(9);
  const Scene s = maker.Make(60, 0.0, 0.0, rotation);
  EssentialSolver solver(s.c, kFocal);
  const SamplerResult r = SequentialSample(solver, AllIndices(60), std::vector<double>(60, 0.5),
                                           std::nullopt, 2.0, SamplerOptions());
  EXPECT_EQ(r.chosen, -1);
  EXPECT_EQ(r.hypotheses, 0);
}

}  // namespace
}  // namespace waymark::visual_slam

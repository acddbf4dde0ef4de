// The SP-model algebra against numeric differentiation, and the state container.

#include <random>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/sp_jacobians.h"
#include "server/laser_slam/sp_state.h"

namespace waymark::laser_slam {
namespace {

constexpr double kStep = 1e-6;
constexpr double kTol = 1e-6;

// Central differences of a vector function of a vector.
template <typename F>
Eigen::MatrixXd Numeric(F f, const Eigen::VectorXd& at) {
  const Eigen::VectorXd f0 = f(at);
  Eigen::MatrixXd j(f0.size(), at.size());
  for (int i = 0; i < at.size(); ++i) {
    Eigen::VectorXd hi = at, lo = at;
    hi(i) += kStep;
    lo(i) -= kStep;
    Eigen::VectorXd d = f(hi) - f(lo);
    // Angles: differences across the wrap must not blow up.
    for (int r = 0; r < d.size(); ++r) {
      if (std::abs(d(r)) > M_PI) d(r) = NormalizeAngle(d(r));
    }
    j.col(i) = d / (2 * kStep);
  }
  return j;
}

Eigen::Vector3d V(const Pose2& p) { return ToVector(p); }

TEST(GeometryTest, ComposeInvertRoundTrip) {
  const Pose2 a{1.0, -2.0, 0.7}, b{0.3, 0.4, -2.9};
  const Pose2 c = Compose(a, b);
  const Pose2 back = Relative(a, c);
  EXPECT_NEAR(back.x, b.x, 1e-12);
  EXPECT_NEAR(back.y, b.y, 1e-12);
  EXPECT_NEAR(back.theta, b.theta, 1e-12);
  const Pose2 i = Compose(a, Invert(a));
  EXPECT_NEAR(i.x, 0.0, 1e-12);
  EXPECT_NEAR(i.y, 0.0, 1e-12);
  EXPECT_NEAR(i.theta, 0.0, 1e-12);
  EXPECT_NEAR(NormalizeAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(NormalizeAngle(-M_PI), M_PI, 1e-12);
}

TEST(GeometryTest, CompositionJacobiansMatchNumeric) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose2 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)};
    const Eigen::MatrixXd j1 = Numeric(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
          return Compose<double>(x, V(b));
        },
        V(a));
    const Eigen::MatrixXd j2 = Numeric(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
          return Compose<double>(V(a), x);
        },
        V(b));
    const Eigen::MatrixXd ji = Numeric(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return Invert<double>(x); }, V(a));
    EXPECT_LT((ComposeJacobianFirst(a, b) - j1).cwiseAbs().maxCoeff(), kTol);
    EXPECT_LT((ComposeJacobianSecond(a, b) - j2).cwiseAbs().maxCoeff(), kTol);
    EXPECT_LT((InvertJacobian(a) - ji).cwiseAbs().maxCoeff(), kTol);
  }
}

// The relative line location written directly in doubles, as the reference for RelateLines.
Eigen::Vector3d RelativeDirect(const Pose2& s, const Pose2& p, const Pose2& q,
                               const Eigen::VectorXd& v) {
  const Eigen::Vector3d a(0, v(0), v(1)), b(v(2), v(3), v(4)), c(0, v(5), v(6));
  const Eigen::Vector3d ls = Compose<double>(V(s), a);
  const Eigen::Vector3d lo = Compose<double>(Compose<double>(Compose<double>(V(p), b), V(q)), c);
  return Compose<double>(Invert<double>(ls), lo);
}

TEST(SpJacobiansTest, RelateLinesMatchesNumeric) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose2 s{u(rng), u(rng), u(rng)}, p{u(rng), u(rng), u(rng)}, q{u(rng), u(rng), u(rng)};
    const RelativeLine rel = RelateLines(s, p, q);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
    const Eigen::Vector3d z = RelativeDirect(s, p, q, zero);
    EXPECT_NEAR(rel.z(0), z(0), 1e-9);
    EXPECT_NEAR(rel.z(1), z(1), 1e-9);
    EXPECT_NEAR(rel.z(2), NormalizeAngle(z(2)), 1e-9);
    const Eigen::MatrixXd j = Numeric(
        [&](const Eigen::VectorXd& v) -> Eigen::VectorXd { return RelativeDirect(s, p, q, v); },
        zero);
    EXPECT_LT((rel.d_a - j.leftCols(2)).cwiseAbs().maxCoeff(), kTol);
    EXPECT_LT((rel.d_b - j.middleCols(2, 3)).cwiseAbs().maxCoeff(), kTol);
    EXPECT_LT((rel.d_c - j.rightCols(2)).cwiseAbs().maxCoeff(), kTol);
  }
}

TEST(SpJacobiansTest, PredictionAndCenteringJacobiansMatchNumeric) {
  const Pose2 u{0.4, -0.1, 0.3};
  const Eigen::MatrixXd jp = Numeric(
      [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
        return Compose<double>(Compose<double>(Invert<double>(V(u)), d), V(u));
      },
      Eigen::VectorXd::Zero(3));
  EXPECT_LT((PredictionJacobian(u) - jp).cwiseAbs().maxCoeff(), kTol);

  const Eigen::Vector3d delta(0.05, -0.02, 0.03);
  const Eigen::MatrixXd jr = Numeric(
      [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
        return Compose<double>(Invert<double>(delta), d);
      },
      delta);
  EXPECT_LT((RobotCenteringJacobian(delta) - jr).cwiseAbs().maxCoeff(), kTol);

  const Eigen::Vector2d line_delta(0.03, 0.02);
  const Eigen::MatrixXd jl = Numeric(
      [&](const Eigen::VectorXd& p) -> Eigen::VectorXd {
        const Eigen::Vector3d rel = Compose<double>(
            Invert<double>(Eigen::Vector3d(0, line_delta(0), line_delta(1))),
            Eigen::Vector3d(0, p(0), p(1)));
        return Eigen::Vector2d(rel(1) - rel(0) * std::tan(rel(2)), rel(2));
      },
      line_delta);
  EXPECT_LT((LineCenteringJacobian(line_delta) - jl).cwiseAbs().maxCoeff(), kTol);
}

// Centering moves the estimate by the correction and re-expresses the perturbation around it:
// samples of the true location must have the same distribution before and after, i.e. mean zero
// in the new parametrisation and covariance Q C Q^T.
TEST(SpJacobiansTest, RobotCenteringLeavesTheDistributionUnchanged) {
  const Pose2 estimate{2.0, 1.0, 0.6};
  const Eigen::Vector3d delta(0.04, -0.03, 0.02);
  Eigen::Matrix3d cov;
  cov << 4e-4, 1e-4, 2e-5,  //
      1e-4, 3e-4, -1e-5,    //
      2e-5, -1e-5, 1e-4;
  const Eigen::Vector3d centred = Compose<double>(V(estimate), delta);
  const Eigen::Matrix3d q = RobotCenteringJacobian(delta);
  const Eigen::Matrix3d expected = q * cov * q.transpose();
  std::mt19937 rng(11);
  std::normal_distribution<double> g;
  const Eigen::Matrix3d l = cov.llt().matrixL();
  const int n = 200000;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d = delta + l * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const Eigen::Vector3d truth = Compose<double>(V(estimate), d);
    Eigen::Vector3d d_new = Compose<double>(Invert<double>(centred), truth);
    d_new(2) = NormalizeAngle(d_new(2));
    mean += d_new;
    second += d_new * d_new.transpose();
  }
  mean /= n;
  const Eigen::Matrix3d sample = second / n - mean * mean.transpose();
  EXPECT_LT(mean.cwiseAbs().maxCoeff(), 2e-4);
  EXPECT_LT((sample - expected).cwiseAbs().maxCoeff(), 0.03 * expected.cwiseAbs().maxCoeff());
}

TEST(SpJacobiansTest, LineCenteringLeavesTheDistributionUnchanged) {
  const Eigen::Vector2d delta(0.02, 0.015);
  Eigen::Matrix2d cov;
  cov << 4e-4, 5e-5, 5e-5, 1e-4;
  const Eigen::Matrix2d q = LineCenteringJacobian(delta);
  const Eigen::Matrix2d expected = q * cov * q.transpose();
  std::mt19937 rng(13);
  std::normal_distribution<double> g;
  const Eigen::Matrix2d l = cov.llt().matrixL();
  const int n = 200000;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p = delta + l * Eigen::Vector2d(g(rng), g(rng));
    const Eigen::Vector3d rel = Compose<double>(Invert<double>(Eigen::Vector3d(0, delta(0), delta(1))),
                                                Eigen::Vector3d(0, p(0), p(1)));
    const Eigen::Vector2d p_new(rel(1) - rel(0) * std::tan(rel(2)), rel(2));
    mean += p_new;
    second += p_new * p_new.transpose();
  }
  mean /= n;
  const Eigen::Matrix2d sample = second / n - mean * mean.transpose();
  EXPECT_LT(mean.cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT((sample - expected).cwiseAbs().maxCoeff(), 0.03 * expected.cwiseAbs().maxCoeff());
}

TEST(SpJacobiansTest, ShiftingTheFrameAlongTheLineKeepsTheLine) {
  // p_y' = p_y + s tan(p_theta): the same line seen from a frame moved by s along it.
  const double s = 1.5;
  const Eigen::Vector2d p(0.01, 0.02);
  const Eigen::Matrix2d j = LineShiftJacobian(s);
  const Eigen::Vector2d linear = j * p;
  EXPECT_NEAR(linear(0), p(0) + s * std::tan(p(1)), 1e-3);
  EXPECT_DOUBLE_EQ(linear(1), p(1));
}

TEST(SpStateTest, RemovingDofsRenumbersAndKeepsCovariance) {
  SpState st;
  const int a = st.AddDofs(2);
  const int b = st.AddDofs(3);
  ASSERT_EQ(st.size(), 8);
  for (int i = 0; i < st.size(); ++i) {
    for (int j = 0; j < st.size(); ++j) st.at(i, j) = 100 * i + j;
  }
  SegmentEntity s1, s2;
  s1.dof = {a, a + 1, -1, -1};
  s2.dof = {b, b + 1, b + 2, -1};
  st.segments = {s1, s2};
  // Remove s1's line: s2's dofs move into the holes; their covariance entries go with them.
  st.segments.erase(st.segments.begin());
  st.RemoveDofs({a, a + 1});
  ASSERT_EQ(st.size(), 6);
  const SegmentEntity& moved = st.segments[0];
  const int old_index[3] = {b, b + 1, b + 2};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(st.at(moved.dof[i], moved.dof[j]), 100 * old_index[i] + old_index[j]);
    }
    EXPECT_EQ(st.at(moved.dof[i], 0), 100 * old_index[i]);  // cross-covariance with the robot
  }
  for (int d : SegmentDofs(moved)) EXPECT_LT(d, st.size());
}

// Copying a state (LaserSlam's copy before each scan) copies every meaningful entry, into a
// smaller state's storage (which grows) and into a larger one's (which is reused), and the copy
// goes on like the original.
TEST(SpStateTest, ACopyHoldsTheSameStateWhateverItsStorage) {
  SpState big;
  big.AddDofs(200);  // storage well over the original's below
  SpState original;
  original.AddDofs(70);  // past the initial 64: grown once
  original.robot = Pose2{1, 2, 0.5};
  original.segments.resize(3);
  original.frozen.resize(2);
  for (int i = 0; i < original.size(); ++i) {
    for (int j = 0; j < original.size(); ++j) original.at(i, j) = 1000 * i + j + 0.5;
  }
  SpState small;
  for (SpState* copy : {&small, &big}) {
    *copy = original;
    ASSERT_EQ(copy->size(), original.size());
    EXPECT_EQ(copy->cov(), original.cov());
    EXPECT_EQ(copy->robot.theta, 0.5);
    EXPECT_EQ(copy->segments.size(), 3u);
    EXPECT_EQ(copy->frozen.size(), 2u);
    const int first = copy->AddDofs(2);  // new rows and columns start at zero
    EXPECT_EQ(copy->cov().row(first).norm(), 0.0);
    EXPECT_EQ(copy->cov().col(first + 1).norm(), 0.0);
    EXPECT_EQ(copy->at(5, 7), original.at(5, 7));
  }
}

}  // namespace
}  // namespace waymark::laser_slam

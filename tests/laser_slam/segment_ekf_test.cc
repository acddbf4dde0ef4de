// Segment merging and map management of the SP-model EKF on hand-built states.

#include "server/laser_slam/segment_ekf.h"

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

// Adds a segment with independent line (and real-endpoint) uncertainty.
void AddSegment(SpState& st, std::uint64_t id, Pose2 frame, double left, double right,
                bool left_real, bool right_real) {
  SegmentEntity s;
  s.id = id;
  s.frame = frame;
  s.left = left;
  s.right = right;
  s.observations = 5;
  s.first_seen_scan = 1;
  s.last_seen_scan = 7;
  const int k = 2 + left_real + right_real;
  const int first = st.AddDofs(k);
  st.at(first, first) = 1e-4;          // p_y: 1 cm
  st.at(first + 1, first + 1) = 1e-5;  // p_theta: 0.2 degrees
  s.dof[0] = first;
  s.dof[1] = first + 1;
  int next = first + 2;
  if (left_real) {
    s.left_type = EndpointType::kReal;
    s.dof[2] = next;
    st.at(next, next) = 1e-3;
    ++next;
  }
  if (right_real) {
    s.right_type = EndpointType::kReal;
    s.dof[3] = next;
    st.at(next, next) = 1e-3;
  }
  st.segments.push_back(s);
}

SegmentEkf MakeEkf() {
  EkfOptions options;
  SegmentEkf ekf(options);
  ekf.state().at(0, 0) = ekf.state().at(1, 1) = 1e-4;
  ekf.state().at(2, 2) = 1e-5;
  return ekf;
}

TEST(SegmentEkfTest, MergesTwoCollinearOverlappingSegments) {
  SegmentEkf ekf = MakeEkf();
  // One wall along y = 1 seen as two pieces: [-2, 0] and [-0.5, 2.5], the second 1 cm off and
  // described from its other end (frame turned by pi) with a real endpoint at x = 2.5.
  AddSegment(ekf.state(), 1, Pose2{-1.0, 1.0, 0.0}, -1.0, 1.0, false, false);
  AddSegment(ekf.state(), 2, Pose2{1.0, 1.01, M_PI}, -1.5, 1.5, true, false);
  ASSERT_EQ(ekf.state().size(), 3 + 2 + 3);

  EXPECT_EQ(ekf.MergeSegments(7), 1);
  ASSERT_EQ(ekf.state().segments.size(), 1u);
  const SegmentEntity& s = ekf.state().segments[0];
  // The union of the extents, in the kept segment's direction.
  const Pose2 a = Compose(s.frame, Pose2{s.left, 0, 0});
  const Pose2 b = Compose(s.frame, Pose2{s.right, 0, 0});
  EXPECT_NEAR(std::min(a.x, b.x), -2.0, 0.02);
  EXPECT_NEAR(std::max(a.x, b.x), 2.5, 0.02);
  // Between the two lines, weighted equally (equal covariances).
  EXPECT_NEAR(a.y, 1.005, 0.003);
  EXPECT_NEAR(b.y, 1.005, 0.003);
  // The real endpoint at x = 2.5 survives with its degree of freedom; the other end is virtual.
  const bool right_is_far = b.x > a.x;
  EXPECT_EQ(right_is_far ? s.right_type : s.left_type, EndpointType::kReal);
  EXPECT_EQ(right_is_far ? s.left_type : s.right_type, EndpointType::kVirtual);
  EXPECT_EQ(ekf.state().size(), 3 + 2 + 1);
  EXPECT_EQ(s.observations, 10);
  // The merged line is more certain than either piece.
  EXPECT_LT(ekf.state().at(s.dof[0], s.dof[0]), 1e-4);
}

TEST(SegmentEkfTest, KeepsParallelWallsApart) {
  SegmentEkf ekf = MakeEkf();
  // Two sides of a 20 cm partition: parallel, overlapping, clearly distinct.
  AddSegment(ekf.state(), 1, Pose2{0.0, 1.0, 0.0}, -1.0, 1.0, false, false);
  AddSegment(ekf.state(), 2, Pose2{0.0, 1.2, 0.0}, -1.0, 1.0, false, false);
  EXPECT_EQ(ekf.MergeSegments(7), 0);
  EXPECT_EQ(ekf.state().segments.size(), 2u);
}

TEST(SegmentEkfTest, KeepsCollinearWallsWithADoorBetweenThemApart) {
  SegmentEkf ekf = MakeEkf();
  AddSegment(ekf.state(), 1, Pose2{-2.0, 1.0, 0.0}, -1.0, 1.0, false, true);
  AddSegment(ekf.state(), 2, Pose2{1.0, 1.0, 0.0}, -1.0, 1.0, true, false);  // 1 m gap
  EXPECT_EQ(ekf.MergeSegments(7), 0);
  EXPECT_EQ(ekf.state().segments.size(), 2u);
}

// AddScan's rollback: the copy keeps half the covariance, and restoring it gives the filter back
// to the bit, both triangles, after the filter moved on (a prediction, a segment more).
TEST(SegmentEkfTest, RestoringTheRollbackCopyGivesTheFilterBackExactly) {
  SegmentEkf ekf = MakeEkf();
  AddSegment(ekf.state(), 1, Pose2{-1.0, 1.0, 0.0}, -1.0, 1.0, false, false);
  AddSegment(ekf.state(), 2, Pose2{1.0, 1.01, M_PI}, -1.5, 1.5, true, false);
  AddSegment(ekf.state(), 3, Pose2{0.0, -1.0, 0.0}, -2.0, 2.0, true, true);
  ekf.set_next_segment_id(4);
  Eigen::Matrix3d noise = Eigen::Matrix3d::Identity() * 1e-3;
  noise(0, 2) = noise(2, 0) = 2e-4;
  ekf.Predict(Pose2{0.3, 0.05, 0.1}, noise);  // the robot correlated with itself
  const SpState before = ekf.state();
  const Eigen::MatrixXd cov_before = before.cov();
  ASSERT_TRUE(cov_before.isApprox(cov_before.transpose(), 0.0));

  SegmentEkf backup = MakeEkf();
  ekf.CopyForRollback(&backup);
  ekf.Predict(Pose2{0.5, -0.1, 0.3}, noise);
  AddSegment(ekf.state(), 4, Pose2{3.0, 0.0, 1.0}, -1.0, 1.0, true, true);
  ekf.set_next_segment_id(7);
  ASSERT_NE(ekf.state().size(), before.size());

  ekf.RestoreFrom(backup);
  ASSERT_EQ(ekf.state().size(), before.size());
  EXPECT_TRUE((ekf.state().cov().array() == cov_before.array()).all());
  EXPECT_EQ(ekf.next_segment_id(), 4u);
  EXPECT_EQ(ekf.state().robot.x, before.robot.x);
  EXPECT_EQ(ekf.state().robot.theta, before.robot.theta);
  ASSERT_EQ(ekf.state().segments.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(ekf.state().segments[i].id, before.segments[i].id);
    EXPECT_EQ(ekf.state().segments[i].frame.y, before.segments[i].frame.y);
  }
}

}  // namespace
}  // namespace waymark::laser_slam

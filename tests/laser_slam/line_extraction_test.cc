#include "server/laser_slam/line_extraction.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::CastScan;
using testing::Lms200Geometry;
using testing::RayCastOptions;
using testing::Wall;

constexpr EndpointType kReal = EndpointType::kReal;
constexpr EndpointType kVirtual = EndpointType::kVirtual;

Eigen::Vector2d LeftPoint(const ObservedSegment& s) {
  return Eigen::Vector2d(s.frame.x, s.frame.y) +
         s.left * Eigen::Vector2d(std::cos(s.frame.theta), std::sin(s.frame.theta));
}
Eigen::Vector2d RightPoint(const ObservedSegment& s) {
  return Eigen::Vector2d(s.frame.x, s.frame.y) +
         s.right * Eigen::Vector2d(std::cos(s.frame.theta), std::sin(s.frame.theta));
}

std::vector<ObservedSegment> Extract(const LaserScan& scan,
                                     const LineExtractionOptions& options = {}) {
  absl::StatusOr<std::vector<ObservedSegment>> r = ExtractSegments(scan, options);
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? *r : std::vector<ObservedSegment>{};
}

std::string Describe(const std::vector<ObservedSegment>& segs) {
  std::string out;
  for (const ObservedSegment& s : segs) {
    const Eigen::Vector2d l = LeftPoint(s), r = RightPoint(s);
    out += "  [" + std::to_string(s.first_beam) + "-" + std::to_string(s.last_beam) + "] (" +
           std::to_string(l.x()) + "," + std::to_string(l.y()) + ")" +
           (s.left_type == kReal ? "R" : "V") + " -> (" + std::to_string(r.x()) + "," +
           std::to_string(r.y()) + ")" + (s.right_type == kReal ? "R" : "V") + "\n";
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// NEES: the covariances must describe the actual error of the fit.

struct NeesResult {
  double line = 0.0;   // mean NEES of (p_y, p_theta) with line_covariance
  double polar = 0.0;  // mean NEES of (rho, phi) with polar_covariance
  double mean_e_y = 0.0, mean_e_theta = 0.0;
};

NeesResult RunNees(const Wall& wall, const RayCastOptions& noise,
                   const LineExtractionOptions& options, int trials, unsigned seed) {
  // WAYMARK_NEES_TRIALS overrides the trial count (to check the estimator with more samples).
  if (const char* env = std::getenv("WAYMARK_NEES_TRIALS"); env != nullptr && std::atoi(env) > 0) {
    trials = std::atoi(env);
  }
  std::mt19937 rng(seed);
  const double wall_angle = std::atan2(wall.b.y() - wall.a.y(), wall.b.x() - wall.a.x());
  double phi_true = wall_angle - M_PI / 2;
  double rho_true = wall.a.x() * std::cos(phi_true) + wall.a.y() * std::sin(phi_true);
  if (rho_true < 0.0) {
    rho_true = -rho_true;
    phi_true = NormalizeAngle(phi_true + M_PI);
  }
  NeesResult res;
  int n = 0;
  for (int t = 0; t < trials; ++t) {
    const LaserScan scan = CastScan({wall}, Pose2{}, Lms200Geometry(), noise, &rng);
    const std::vector<ObservedSegment> segs = Extract(scan, options);
    EXPECT_EQ(segs.size(), 1u) << Describe(segs);
    if (segs.size() != 1) continue;
    const ObservedSegment& s = segs[0];
    // True line in the estimated segment frame.
    double e_theta = NormalizeAngle(wall_angle - s.frame.theta);
    if (std::abs(e_theta) > M_PI / 2) e_theta = NormalizeAngle(e_theta + M_PI);
    const double c = std::cos(s.frame.theta), sn = std::sin(s.frame.theta);
    const double dx = wall.a.x() - s.frame.x, dy = wall.a.y() - s.frame.y;
    const double qx = c * dx + sn * dy, qy = -sn * dx + c * dy;
    const double e_y = qy - qx * std::tan(e_theta);
    const Eigen::Vector2d e(e_y, e_theta);
    res.line += e.dot(s.line_covariance.ldlt().solve(e));
    const Eigen::Vector2d ep(rho_true - s.rho, NormalizeAngle(phi_true - s.phi));
    res.polar += ep.dot(s.polar_covariance.ldlt().solve(ep));
    res.mean_e_y += e_y;
    res.mean_e_theta += e_theta;
    ++n;
  }
  if (n > 0) {
    res.line /= n;
    res.polar /= n;
    res.mean_e_y /= n;
    res.mean_e_theta /= n;
  }
  return res;
}

// A wall along the line with normal angle phi at distance rho, from abscissa tau0 to tau1.
Wall PolarWall(double rho, double phi, double tau0, double tau1) {
  const Eigen::Vector2d n(std::cos(phi), std::sin(phi)), t(-std::sin(phi), std::cos(phi));
  return Wall{rho * n + tau0 * t, rho * n + tau1 * t};
}

void ExpectConsistent(const char* name, const NeesResult& r) {
  std::cout << name << ": mean NEES line " << r.line << ", polar " << r.polar << ", mean e_y "
            << r.mean_e_y << ", mean e_theta " << r.mean_e_theta << "\n";
  EXPECT_GT(r.line, 1.7) << name;
  EXPECT_LT(r.line, 2.4) << name;
  EXPECT_GT(r.polar, 1.7) << name;
  EXPECT_LT(r.polar, 2.4) << name;
}

TEST(LineExtractionNees, FrontalWallRangeNoise) {
  LineExtractionOptions o;
  o.range_sigma = 0.01;
  o.bearing_sigma = 0.0;
  RayCastOptions noise;
  noise.range_sigma = 0.01;
  ExpectConsistent("frontal", RunNees(Wall{{3.0, -2.0}, {3.0, 2.0}}, noise, o, 500, 1));
}

TEST(LineExtractionNees, ObliqueOffCentreWallRangeNoise) {
  // Normal at -0.6 rad, 1.5 m away; the segment spans abscissae 1.0 .. 3.5 m from the foot of the
  // perpendicular, so the midpoint has a 2.25 m moment arm.
  LineExtractionOptions o;
  o.range_sigma = 0.01;
  o.bearing_sigma = 0.0;
  RayCastOptions noise;
  noise.range_sigma = 0.01;
  ExpectConsistent("oblique", RunNees(PolarWall(1.5, -0.6, 1.0, 3.5), noise, o, 500, 2));
  // Same line, walked the other way round (the segment frame's orientation flips).
  ExpectConsistent("oblique, other side",
                   RunNees(PolarWall(1.5, 0.9, -3.5, -1.0), noise, o, 500, 3));
}

TEST(LineExtractionNees, ObliqueWallRangeAndBearingNoise) {
  LineExtractionOptions o;
  o.range_sigma = 0.01;
  o.bearing_sigma = 0.002;
  RayCastOptions noise;
  noise.range_sigma = 0.01;
  noise.bearing_sigma = 0.002;
  ExpectConsistent("oblique, range+bearing",
                   RunNees(PolarWall(1.5, -0.6, 1.0, 3.5), noise, o, 500, 4));
  ExpectConsistent("frontal far, range+bearing",
                   RunNees(Wall{{5.0, -2.5}, {5.0, 1.0}}, noise, o, 500, 5));
}

// Real endpoints: the error of the endpoint's abscissa (true end projected on the segment's x axis
// minus the estimate) against left_variance / right_variance. The laser heading is jittered
// uniformly over one beam increment per trial, so where the true end falls between two beams is
// random, as the quantisation term of the variance assumes.
struct EndpointCheck {
  Eigen::Vector2d point;  // true end in the world frame
  bool left;              // which endpoint of the segment it should be
};

double EndpointNees(const std::vector<Wall>& walls, double rho, const EndpointCheck& check,
                    int trials, unsigned seed) {
  if (const char* env = std::getenv("WAYMARK_NEES_TRIALS"); env != nullptr && std::atoi(env) > 0) {
    trials = std::atoi(env);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(0.0, M_PI / 360);
  RayCastOptions noise;
  noise.range_sigma = 0.01;
  LineExtractionOptions o;
  o.bearing_sigma = 0.0;
  double sum = 0.0;
  int n = 0;
  for (int t = 0; t < trials; ++t) {
    const Pose2 pose{0.0, 0.0, jitter(rng)};
    const std::vector<ObservedSegment> segs =
        Extract(CastScan(walls, pose, Lms200Geometry(), noise, &rng), o);
    const Pose2 end = Relative(pose, Pose2{check.point.x(), check.point.y(), 0.0});
    for (const ObservedSegment& s : segs) {
      if (std::abs(s.rho - rho) > 0.05) continue;
      const EndpointType type = check.left ? s.left_type : s.right_type;
      EXPECT_EQ(type, kReal) << "trial " << t << "\n" << Describe(segs);
      if (type != kReal) continue;
      const double c = std::cos(s.frame.theta), sn = std::sin(s.frame.theta);
      const double x_true = c * (end.x - s.frame.x) + sn * (end.y - s.frame.y);
      const double e = x_true - (check.left ? s.left : s.right);
      sum += e * e / (check.left ? s.left_variance : s.right_variance);
      ++n;
    }
  }
  EXPECT_GT(n, trials * 9 / 10);
  return n > 0 ? sum / n : 0.0;
}

TEST(LineExtractionNees, RealEndpointVariances) {
  // A wall end with open space behind (half-gap model) and a room corner (line intersection).
  const std::vector<Wall> panel = {{{3.0, -1.0}, {3.0, 1.0}}, {{5.5, -5.0}, {5.5, 5.0}}};
  const double wall_end = EndpointNees(panel, 3.0, {{3.0, 1.0}, false}, 500, 21);
  const std::vector<Wall> room = Box(-2, -2, 4, 3);
  const double corner = EndpointNees(room, 4.0, {{4.0, 3.0}, false}, 500, 22);
  std::cout << "endpoint NEES (1 dof): wall end " << wall_end << ", corner " << corner << "\n";
  EXPECT_GT(wall_end, 0.6);
  EXPECT_LT(wall_end, 1.5);
  EXPECT_GT(corner, 0.6);
  EXPECT_LT(corner, 1.5);
}

// ---------------------------------------------------------------------------------------------
// Segments and endpoints in scenes with known answers.

void ExpectNear(const Eigen::Vector2d& got, const Eigen::Vector2d& want, double tol,
                const std::string& what) {
  EXPECT_LT((got - want).norm(), tol) << what << ": got (" << got.x() << ", " << got.y()
                                      << "), want (" << want.x() << ", " << want.y() << ")";
}

TEST(LineExtraction, SquareRoomFromInside) {
  std::mt19937 rng(7);
  RayCastOptions noise;
  noise.range_sigma = 0.005;
  const LaserScan scan = CastScan(Box(-2, -2, 4, 3), Pose2{}, Lms200Geometry(), noise, &rng);
  const std::vector<ObservedSegment> segs = Extract(scan);
  ASSERT_EQ(segs.size(), 3u) << Describe(segs);
  // Bottom wall: cut by the field of view at (0, -2), corner at (4, -2).
  EXPECT_EQ(segs[0].left_type, kVirtual);
  EXPECT_EQ(segs[0].right_type, kReal);
  ExpectNear(LeftPoint(segs[0]), {0.0, -2.0}, 0.05, "bottom left");
  ExpectNear(RightPoint(segs[0]), {4.0, -2.0}, 0.03, "bottom right corner");
  EXPECT_EQ(segs[0].first_beam, 0);
  // Far wall: corners at both ends.
  EXPECT_EQ(segs[1].left_type, kReal);
  EXPECT_EQ(segs[1].right_type, kReal);
  ExpectNear(LeftPoint(segs[1]), {4.0, -2.0}, 0.03, "far wall left corner");
  ExpectNear(RightPoint(segs[1]), {4.0, 3.0}, 0.03, "far wall right corner");
  EXPECT_NEAR(segs[1].rho, 4.0, 0.01);
  EXPECT_NEAR(segs[1].phi, 0.0, 0.005);
  // Top wall: corner at (4, 3), cut by the field of view at (0, 3).
  EXPECT_EQ(segs[2].left_type, kReal);
  EXPECT_EQ(segs[2].right_type, kVirtual);
  ExpectNear(LeftPoint(segs[2]), {4.0, 3.0}, 0.03, "top right corner");
  ExpectNear(RightPoint(segs[2]), {0.0, 3.0}, 0.05, "top left");
  EXPECT_EQ(segs[2].last_beam, 360);
  for (const ObservedSegment& s : segs) {
    EXPECT_NEAR(s.left, -s.right, 1e-9);
    EXPECT_GT(s.left_variance, 0.0);
    EXPECT_GT(s.right_variance, 0.0);
    EXPECT_EQ(s.point_count, s.last_beam - s.first_beam + 1);
    EXPECT_GT(s.line_covariance.determinant(), 0.0);
    // With increasing bearings the frame's x axis runs counter-clockwise around the sensor, so its
    // y axis points back towards the sensor.
    const Eigen::Vector2d y_axis(-std::sin(s.frame.theta), std::cos(s.frame.theta));
    EXPECT_LT(y_axis.dot(Eigen::Vector2d(s.frame.x, s.frame.y)), 0.0);
  }
}

TEST(LineExtraction, RoomSeenFromAnOffsetRotatedPose) {
  // The same extraction must work whatever the laser's pose: compare with the walls in the laser
  // frame.
  const Pose2 pose{0.5, -0.3, 0.4};
  const LaserScan scan = CastScan(Box(-2, -2, 4, 3), pose, Lms200Geometry(), {}, nullptr);
  const std::vector<ObservedSegment> segs = Extract(scan);
  ASSERT_GE(segs.size(), 2u) << Describe(segs);
  // The corner (4, 3) seen from the pose.
  const Pose2 corner = Relative(pose, Pose2{4.0, 3.0, 0.0});
  int corners = 0;
  for (const ObservedSegment& s : segs) {
    if (s.left_type == kReal && (LeftPoint(s) - Eigen::Vector2d(corner.x, corner.y)).norm() < 0.03)
      ++corners;
    if (s.right_type == kReal &&
        (RightPoint(s) - Eigen::Vector2d(corner.x, corner.y)).norm() < 0.03)
      ++corners;
  }
  EXPECT_EQ(corners, 2) << Describe(segs);
}

TEST(LineExtraction, WallCutByMaxRangeHasVirtualEnd) {
  // A corridor 3 m wide; its walls leave the 6 m range at x = sqrt(36 - 1.5^2) = 5.81 m.
  const std::vector<Wall> walls = {{{-1.0, -1.5}, {20.0, -1.5}}, {{-1.0, 1.5}, {20.0, 1.5}}};
  std::mt19937 rng(11);
  RayCastOptions noise;
  noise.range_sigma = 0.005;
  noise.sensor_range = 30.0;
  const std::vector<ObservedSegment> segs =
      Extract(CastScan(walls, Pose2{}, Lms200Geometry(), noise, &rng));
  ASSERT_EQ(segs.size(), 2u) << Describe(segs);
  for (const ObservedSegment& s : segs) {
    EXPECT_EQ(s.left_type, kVirtual) << Describe(segs);
    EXPECT_EQ(s.right_type, kVirtual) << Describe(segs);
  }
  EXPECT_NEAR(RightPoint(segs[0]).x(), 5.81, 0.25);
  EXPECT_NEAR(LeftPoint(segs[1]).x(), 5.81, 0.25);
  EXPECT_NEAR(LeftPoint(segs[0]).x(), 0.0, 0.05);  // field of view edge
  EXPECT_NEAR(RightPoint(segs[1]).x(), 0.0, 0.05);
}

TEST(LineExtraction, WallPartlyHiddenBehindAnOccluder) {
  // Back wall x = 4, a panel in front of it at x = 2 from y = 0.5 to 1.2, which hides the wall
  // from y = 1.0 to 2.4.
  const std::vector<Wall> walls = {{{4.0, -3.0}, {4.0, 3.0}}, {{2.0, 0.5}, {2.0, 1.2}}};
  std::mt19937 rng(13);
  RayCastOptions noise;
  noise.range_sigma = 0.005;
  const std::vector<ObservedSegment> segs =
      Extract(CastScan(walls, Pose2{}, Lms200Geometry(), noise, &rng));
  ASSERT_EQ(segs.size(), 3u) << Describe(segs);
  // Lower part of the back wall: its end beyond the scan's returns (no return), then the occlusion.
  EXPECT_EQ(segs[0].left_type, kVirtual);
  EXPECT_EQ(segs[0].right_type, kVirtual);
  EXPECT_NEAR(RightPoint(segs[0]).y(), 1.0, 0.05);
  // The panel: we see the back wall past both its ends -> real endpoints, at the panel's ends.
  EXPECT_EQ(segs[1].left_type, kReal);
  EXPECT_EQ(segs[1].right_type, kReal);
  ExpectNear(LeftPoint(segs[1]), {2.0, 0.5}, 0.02, "panel bottom");
  ExpectNear(RightPoint(segs[1]), {2.0, 1.2}, 0.02, "panel top");
  // Upper part of the back wall starts at the occlusion.
  EXPECT_EQ(segs[2].left_type, kVirtual);
  EXPECT_NEAR(LeftPoint(segs[2]).y(), 2.4, 0.05);
  EXPECT_NEAR(segs[0].rho, 4.0, 0.01);
  EXPECT_NEAR(segs[2].rho, 4.0, 0.02);
}

TEST(LineExtraction, WallEndingWithOpenSpaceBehind) {
  // A 2 m wall 3 m ahead with open space (up to a far wall at 5.5 m) behind both its ends.
  const std::vector<Wall> walls = {{{3.0, -1.0}, {3.0, 1.0}}, {{5.5, -5.0}, {5.5, 5.0}}};
  std::mt19937 rng(17);
  RayCastOptions noise;
  noise.range_sigma = 0.01;
  const std::vector<ObservedSegment> segs =
      Extract(CastScan(walls, Pose2{}, Lms200Geometry(), noise, &rng));
  const ObservedSegment* front = nullptr;
  for (const ObservedSegment& s : segs) {
    if (std::abs(s.rho - 3.0) < 0.05) front = &s;
  }
  ASSERT_NE(front, nullptr) << Describe(segs);
  EXPECT_EQ(front->left_type, kReal);
  EXPECT_EQ(front->right_type, kReal);
  ExpectNear(LeftPoint(*front), {3.0, -1.0}, 0.03, "wall end");
  ExpectNear(RightPoint(*front), {3.0, 1.0}, 0.03, "wall end");
  EXPECT_NEAR(front->right - front->left, 2.0, 0.05);
  // The far wall pieces next to the front wall are occluded there.
  for (const ObservedSegment& s : segs) {
    if (&s == front) continue;
    if (s.last_beam + 1 == front->first_beam) {
      EXPECT_EQ(s.right_type, kVirtual);
    }
    if (s.first_beam - 1 == front->last_beam) {
      EXPECT_EQ(s.left_type, kVirtual);
    }
  }
}

TEST(LineExtraction, WallNearlyParallelToTheBeamsIsDropped) {
  // A 1.5 m wall starting 2 m away at bearing 20 degrees, running at 30 degrees: about 7 degrees of
  // incidence at its midpoint.
  const double a0 = 20.0 * M_PI / 180, dir = 30.0 * M_PI / 180;
  const Eigen::Vector2d a(2.0 * std::cos(a0), 2.0 * std::sin(a0));
  const Wall wall{a, a + 1.5 * Eigen::Vector2d(std::cos(dir), std::sin(dir))};
  const LaserScan scan = CastScan({wall}, Pose2{}, Lms200Geometry(), {}, nullptr);
  EXPECT_TRUE(Extract(scan).empty()) << Describe(Extract(scan));
  LineExtractionOptions o;
  o.min_incidence = 0.05;
  const std::vector<ObservedSegment> segs = Extract(scan, o);
  ASSERT_EQ(segs.size(), 1u) << Describe(segs);
  EXPECT_NEAR(segs[0].right - segs[0].left, 1.5, 0.2);
}

TEST(LineExtraction, ShortAndSparseSegmentsAreDropped) {
  // 0.2 m wide: shorter than min_length.
  const LaserScan short_scan =
      CastScan({Wall{{2.0, -0.1}, {2.0, 0.1}}}, Pose2{}, Lms200Geometry(), {}, nullptr);
  EXPECT_TRUE(Extract(short_scan).empty());
  LineExtractionOptions o;
  o.min_length = 0.1;
  EXPECT_EQ(Extract(short_scan, o).size(), 1u);

  // Five points only (beams 5 degrees apart).
  ScanGeometry coarse;
  coarse.angle_min = -M_PI / 2;
  coarse.angle_increment = 5.0 * M_PI / 180;
  coarse.beam_count = 37;
  const LaserScan sparse = CastScan({Wall{{2.0, -0.4}, {2.0, 0.4}}}, Pose2{}, coarse, {}, nullptr);
  EXPECT_TRUE(Extract(sparse).empty());
  LineExtractionOptions few;
  few.min_points = 4;
  const std::vector<ObservedSegment> segs = Extract(sparse, few);
  ASSERT_EQ(segs.size(), 1u);
  EXPECT_EQ(segs[0].point_count, 5);
}

TEST(LineExtraction, NoReturnsSplitSegments) {
  const Wall wall{{3.0, -3.0}, {3.0, 3.0}};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (float bad : {nan, inf, -inf, -1.0f, 0.0f, 0.01f /* < min_range */, 8.0f /* no-return */,
                    7.0f /* > max_range */}) {
    SCOPED_TRACE(bad);
    LaserScan scan = CastScan({wall}, Pose2{}, Lms200Geometry(8.0), {}, nullptr);
    scan.ranges[180] = bad;
    const std::vector<ObservedSegment> segs = Extract(scan);
    ASSERT_EQ(segs.size(), 2u) << Describe(segs);
    EXPECT_EQ(segs[0].last_beam, 179);
    EXPECT_EQ(segs[1].first_beam, 181);
    EXPECT_EQ(segs[0].right_type, kVirtual);
    EXPECT_EQ(segs[1].left_type, kVirtual);
    EXPECT_NEAR(segs[0].rho, 3.0, 1e-4);
    EXPECT_NEAR(segs[1].rho, 3.0, 1e-4);
  }
  // Nothing but no-returns.
  LaserScan empty = CastScan({}, Pose2{}, Lms200Geometry(8.0), {}, nullptr);
  EXPECT_TRUE(Extract(empty).empty());
  for (float& r : empty.ranges) r = nan;
  EXPECT_TRUE(Extract(empty).empty());
}

TEST(LineExtraction, RejectsMalformedScans) {
  LaserScan scan =
      CastScan({Wall{{3.0, -3.0}, {3.0, 3.0}}}, Pose2{}, Lms200Geometry(), {}, nullptr);
  scan.ranges.pop_back();
  absl::StatusOr<std::vector<ObservedSegment>> r = ExtractSegments(scan, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(r.status().message()), ::testing::HasSubstr("360"));
  EXPECT_THAT(std::string(r.status().message()), ::testing::HasSubstr("361"));

  LaserScan bad_geometry = scan;
  bad_geometry.geometry.angle_increment = 0.0;
  EXPECT_EQ(ExtractSegments(bad_geometry, {}).status().code(), absl::StatusCode::kInvalidArgument);

  LaserScan ok = CastScan({Wall{{3.0, -3.0}, {3.0, 3.0}}}, Pose2{}, Lms200Geometry(), {}, nullptr);
  LineExtractionOptions bad_options;
  bad_options.range_sigma = 0.0;
  EXPECT_EQ(ExtractSegments(ok, bad_options).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(LineExtraction, NegativeIncrementGivesTheMirroredResult) {
  std::mt19937 rng(19);
  RayCastOptions noise;
  noise.range_sigma = 0.005;
  const std::vector<Wall> walls = [] {
    std::vector<Wall> w = Box(-2, -2, 4, 3);
    w.push_back({{2.0, 0.5}, {2.0, 1.2}});
    return w;
  }();
  const LaserScan up = CastScan(walls, Pose2{}, Lms200Geometry(), noise, &rng);
  LaserScan down = up;
  down.geometry.angle_min = M_PI / 2;
  down.geometry.angle_increment = -M_PI / 360;
  std::reverse(down.ranges.begin(), down.ranges.end());
  const std::vector<ObservedSegment> a = Extract(up);
  const std::vector<ObservedSegment> b = Extract(down);
  ASSERT_EQ(a.size(), b.size()) << Describe(a) << "vs\n" << Describe(b);
  ASSERT_GE(a.size(), 4u) << Describe(a);
  const int n = static_cast<int>(a.size());
  for (int i = 0; i < n; ++i) {
    const ObservedSegment& x = a[i];
    const ObservedSegment& y = b[n - 1 - i];
    SCOPED_TRACE(i);
    EXPECT_NEAR(x.rho, y.rho, 1e-9);
    EXPECT_NEAR(NormalizeAngle(x.phi - y.phi), 0.0, 1e-9);
    EXPECT_NEAR(x.frame.x, y.frame.x, 1e-9);
    EXPECT_NEAR(x.frame.y, y.frame.y, 1e-9);
    EXPECT_NEAR(std::abs(NormalizeAngle(x.frame.theta - y.frame.theta)), M_PI, 1e-9);
    EXPECT_LT((LeftPoint(x) - RightPoint(y)).norm(), 1e-9);
    EXPECT_LT((RightPoint(x) - LeftPoint(y)).norm(), 1e-9);
    EXPECT_EQ(x.left_type, y.right_type);
    EXPECT_EQ(x.right_type, y.left_type);
    EXPECT_NEAR(x.left_variance, y.right_variance, 1e-12);
    EXPECT_NEAR(x.right_variance, y.left_variance, 1e-12);
    EXPECT_EQ(x.first_beam, 360 - y.last_beam);
    EXPECT_EQ(x.last_beam, 360 - y.first_beam);
    EXPECT_TRUE(x.polar_covariance.isApprox(y.polar_covariance, 1e-9));
    // p_y flips sign with the frame (rotated by pi), p_theta does not.
    EXPECT_NEAR(x.line_covariance(0, 0), y.line_covariance(0, 0), 1e-12);
    EXPECT_NEAR(x.line_covariance(1, 1), y.line_covariance(1, 1), 1e-12);
    EXPECT_NEAR(x.line_covariance(0, 1), -y.line_covariance(0, 1), 1e-12);
  }
}

}  // namespace
}  // namespace waymark::laser_slam

namespace waymark::laser_slam {
namespace {

TEST(LineExtraction, GarbageScansNeverBreakIt) {
  // Random geometries and readings (with NaN, inf, negative, tiny and huge values mixed in): the
  // extraction returns OK and every segment is well formed.
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(), -1.0f, 0.0f, 1e-30f, 1e30f};
  int total = 0;
  for (int trial = 0; trial < 300; ++trial) {
    LaserScan scan;
    scan.geometry.beam_count = 2 + static_cast<int>(u(rng) * 800);
    const double span = (0.1 + u(rng) * (2 * M_PI - 0.1)) * (u(rng) < 0.5 ? -1.0 : 1.0);
    scan.geometry.angle_increment = span / (scan.geometry.beam_count - 1);
    scan.geometry.angle_min = (u(rng) - 0.5) * 2 * M_PI;
    scan.geometry.no_return_range = u(rng) < 0.5 ? 0.0 : 5.0;
    scan.ranges.resize(scan.geometry.beam_count);
    // Piecewise-smooth ranges (so that lines are found) plus junk.
    double r = 1.0 + 4.0 * u(rng);
    for (float& x : scan.ranges) {
      if (u(rng) < 0.05) r = 0.1 + 7.0 * u(rng);
      r += 0.01 * (u(rng) - 0.5);
      x = u(rng) < 0.05 ? specials[static_cast<int>(u(rng) * 7) % 7] : static_cast<float>(r);
    }
    absl::StatusOr<std::vector<ObservedSegment>> segs = ExtractSegments(scan, {});
    ASSERT_TRUE(segs.ok()) << segs.status();
    total += static_cast<int>(segs->size());
    for (const ObservedSegment& s : *segs) {
      EXPECT_LT(s.left, s.right);
      EXPECT_TRUE(std::isfinite(s.frame.x) && std::isfinite(s.frame.y) &&
                  std::isfinite(s.frame.theta));
      EXPECT_GE(s.rho, 0.0);
      EXPECT_GT(s.polar_covariance.determinant(), 0.0);
      EXPECT_GT(s.line_covariance.determinant(), 0.0);
      EXPECT_GT(s.left_variance, 0.0);
      EXPECT_GT(s.right_variance, 0.0);
      EXPECT_TRUE(std::isfinite(s.left_variance) && std::isfinite(s.right_variance));
      EXPECT_GE(s.point_count, 6);
      EXPECT_LE(0, s.first_beam);
      EXPECT_LT(s.last_beam, scan.geometry.beam_count);
    }
  }
  std::cout << total << " segments in 300 garbage scans\n";
  EXPECT_GT(total, 100);  // the scans do contain lines: the checks above are not vacuous
}

}  // namespace
}  // namespace waymark::laser_slam

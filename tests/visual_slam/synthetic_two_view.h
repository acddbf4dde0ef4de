#ifndef WAYMARK_TESTS_VISUAL_SLAM_SYNTHETIC_TWO_VIEW_H_
#define WAYMARK_TESTS_VISUAL_SLAM_SYNTHETIC_TWO_VIEW_H_

// Synthetic two-view scenes with known answers for the geometry tests: random 3-D points in front
// of a 640x480 camera (focal 500 px), seen from a reference camera and a current camera related by
// a known motion, with pixel noise and a fraction of outliers (current positions anywhere in the
// image).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "server/visual_slam/geometry/correspondence.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam::testing {

constexpr double kFocal = 500;
constexpr double kHalfWidth = 320 / kFocal, kHalfHeight = 240 / kFocal;  // normalized image edges
constexpr double kPi = 3.14159265358979323846;

inline double Deg(double radians) { return radians * 180 / kPi; }

// Rotation by roll/pitch/yaw in degrees (x, then y, then z) and a translation in metres.
inline Motion MakeMotion(double rx_deg, double ry_deg, double rz_deg, Eigen::Vector3d t) {
  Motion m;
  m.R = (Eigen::AngleAxisd(rz_deg * kPi / 180, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(ry_deg * kPi / 180, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(rx_deg * kPi / 180, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
  m.t = t;
  return m;
}

inline Eigen::Vector2d Project(const Eigen::Vector3d& X) { return X.head<2>() / X.z(); }

inline bool InImage(const Eigen::Vector3d& X) {
  return X.z() > 0.1 && std::abs(X.x() / X.z()) < kHalfWidth &&
         std::abs(X.y() / X.z()) < kHalfHeight;
}

// Angle of R_a^T R_b in degrees.
inline double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = 0.5 * ((a.transpose() * b).trace() - 1);
  return Deg(std::acos(std::min(1.0, std::max(-1.0, c))));
}

inline double DirectionErrorDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return Deg(std::acos(std::min(1.0, std::max(-1.0, c))));
}

// 0, 1, ..., n - 1: every correspondence of a scene, for the solvers' Refine and Score.
inline std::vector<int> AllIndices(int n) {
  std::vector<int> v(n);
  std::iota(v.begin(), v.end(), 0);
  return v;
}

struct Scene {
  std::vector<Correspondence> c;
  std::vector<bool> inlier;             // true for pairs that follow the motion
  std::vector<Eigen::Vector3d> points;  // true 3-D point in the reference camera (inliers)
};

class SceneMaker {
 public:
  explicit SceneMaker(uint32_t seed) : rng_(seed) {}

  double Uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
  }
  double Gauss(double sigma) { return std::normal_distribution<double>(0, sigma)(rng_); }

  // A random point in the reference camera that both cameras see under `motion`.
  Eigen::Vector3d VisiblePoint(const Motion& motion, double z_lo = 2, double z_hi = 6) {
    for (;;) {
      const double z = Uniform(z_lo, z_hi);
      const Eigen::Vector3d X(Uniform(-kHalfWidth, kHalfWidth) * z,
                              Uniform(-kHalfHeight, kHalfHeight) * z, z);
      if (InImage(X) && InImage(motion.R * X + motion.t)) return X;
    }
  }

  Eigen::Vector2d Noise(double sigma_px) {
    return Eigen::Vector2d(Gauss(sigma_px), Gauss(sigma_px)) / kFocal;
  }

  // A pair that follows `motion`: reference and current noisy by sigma_px, exact depth.
  Correspondence Pair(const Eigen::Vector3d& X, const Motion& motion, double sigma_px) {
    Correspondence c;
    c.reference = Project(X) + Noise(sigma_px);
    c.current = Project(motion.R * X + motion.t) + Noise(sigma_px);
    c.reference_point = X;
    c.hamming = 10;
    return c;
  }

  // An outlier: a real reference point matched to a random place of the current image.
  Correspondence Outlier(const Eigen::Vector3d& X) {
    Correspondence c;
    c.reference = Project(X);
    c.current =
        Eigen::Vector2d(Uniform(-kHalfWidth, kHalfWidth), Uniform(-kHalfHeight, kHalfHeight));
    c.reference_point = X;
    c.hamming = 10;
    return c;
  }

  // n pairs, round(n * outlier_fraction) of them outliers at random indices.
  Scene Make(int n, double outlier_fraction, double sigma_px, const Motion& motion) {
    std::vector<bool> flags(n, true);
    const int outliers = static_cast<int>(std::lround(n * outlier_fraction));
    for (int i = 0; i < outliers && i < n; ++i) flags[i] = false;
    std::shuffle(flags.begin(), flags.end(), rng_);
    Scene s;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d X = VisiblePoint(motion);
      const bool inlier = flags[i];
      s.c.push_back(inlier ? Pair(X, motion, sigma_px) : Outlier(X));
      s.inlier.push_back(inlier);
      s.points.push_back(X);
    }
    return s;
  }

 private:
  std::mt19937 rng_;
};

}  // namespace waymark::visual_slam::testing

#endif  // WAYMARK_TESTS_VISUAL_SLAM_SYNTHETIC_TWO_VIEW_H_

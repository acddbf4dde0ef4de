#include "server/visual_slam/geometry/static_test.h"

#include <cmath>
#include <limits>

#include "server/visual_slam/geometry/two_view.h"

namespace waymark::visual_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

double PredictionDistancePx(const Correspondence& c, const Motion& motion, double focal_px) {
  double d = kInf;
  if (c.reference_point) {
    const Eigen::Vector3d X = motion.R * *c.reference_point + motion.t;
    if (X.z() > 0) d = (X.head<2>() / X.z() - c.current).norm();
  } else if (motion.t.norm() < 1e-9) {
    const Eigen::Vector3d x = motion.R * Eigen::Vector3d(c.reference.x(), c.reference.y(), 1);
    if (x.z() > 0) d = (x.head<2>() / x.z() - c.current).norm();
  } else {
    d = EpipolarLineDistance(EssentialOf(motion), c.reference, c.current);
  }
  d *= focal_px;
  return std::isfinite(d) ? d : kInf;
}

std::vector<bool> StaticTest(const std::vector<Correspondence>& c, const Motion& motion,
                             const StaticTestOptions& options) {
  std::vector<bool> is_static(c.size(), false);
  for (size_t i = 0; i < c.size(); ++i) {
    is_static[i] = c[i].hamming < options.max_hamming &&
                   PredictionDistancePx(c[i], motion, options.focal_px) <= options.distance_px;
  }
  return is_static;
}

}  // namespace waymark::visual_slam

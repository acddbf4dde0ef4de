#include "server/laser_slam/line_fit.h"

#include <cmath>

#include <Eigen/LU>

namespace waymark::laser_slam {

double PolarLine::nx() const { return std::cos(phi); }
double PolarLine::ny() const { return std::sin(phi); }
double PolarLine::Distance(double x, double y) const {
  return x * std::cos(phi) + y * std::sin(phi) - rho;
}
double PolarLine::Tau(double x, double y) const { return -x * std::sin(phi) + y * std::cos(phi); }

namespace {

// Orthogonal-regression line through points[first..last] with weights from `weight(i)`.
// Returns false when the weighted scatter is degenerate (all points coincide).
template <typename WeightFn>
bool WeightedFit(const std::vector<ScanPoint>& pts, int first, int last, WeightFn weight,
                 double* rho, double* phi) {
  double sw = 0.0, sx = 0.0, sy = 0.0;
  for (int i = first; i <= last; ++i) {
    const double w = weight(i);
    sw += w;
    sx += w * pts[i].x;
    sy += w * pts[i].y;
  }
  if (!(sw > 0.0)) return false;
  const double xm = sx / sw, ym = sy / sw;
  double sxx = 0.0, syy = 0.0, sxy = 0.0;
  for (int i = first; i <= last; ++i) {
    const double w = weight(i);
    const double dx = pts[i].x - xm, dy = pts[i].y - ym;
    sxx += w * dx * dx;
    syy += w * dy * dy;
    sxy += w * dx * dy;
  }
  if (!(sxx + syy > 0.0)) return false;
  // Minimise sum w ((x - xm) cos phi + (y - ym) sin phi)^2
  //   = (sxx + syy) / 2 + (sxx - syy) / 2 cos 2phi + sxy sin 2phi.
  double p = 0.5 * std::atan2(-2.0 * sxy, syy - sxx);
  double r = xm * std::cos(p) + ym * std::sin(p);
  if (r < 0.0) {
    r = -r;
    p += M_PI;
  }
  if (p > M_PI) p -= 2.0 * M_PI;
  if (p <= -M_PI) p += 2.0 * M_PI;
  *rho = r;
  *phi = p;
  return true;
}

}  // namespace

PolarLine FitLine(const std::vector<ScanPoint>& pts, int first, int last, double range_sigma,
                  double bearing_sigma) {
  PolarLine line;
  if (last - first + 1 < 2) return line;
  double rho = 0.0, phi = 0.0;
  if (!WeightedFit(
          pts, first, last, [](int) { return 1.0; }, &rho, &phi))
    return line;
  const double vr = range_sigma * range_sigma, vb = bearing_sigma * bearing_sigma;
  // Residual variance of reading i for a line with normal angle phi.
  auto residual_variance = [&](int i, double cp, double sp) {
    const ScanPoint& q = pts[i];
    const double ca = q.c * cp + q.s * sp;  // cos(a_i - phi)
    const double sa = q.s * cp - q.c * sp;  // sin(a_i - phi)
    return vr * ca * ca + q.r * q.r * vb * sa * sa;
  };
  for (int iter = 0; iter < 2; ++iter) {
    const double cp = std::cos(phi), sp = std::sin(phi);
    double new_rho = rho, new_phi = phi;
    if (!WeightedFit(
            pts, first, last, [&](int i) { return 1.0 / residual_variance(i, cp, sp); }, &new_rho,
            &new_phi)) {
      break;
    }
    rho = new_rho;
    phi = new_phi;
  }
  // Fisher information of (rho, phi) at the estimate.
  const double cp = std::cos(phi), sp = std::sin(phi);
  double i00 = 0.0, i01 = 0.0, i11 = 0.0;
  for (int i = first; i <= last; ++i) {
    const double w = 1.0 / residual_variance(i, cp, sp);
    const double tau = -pts[i].x * sp + pts[i].y * cp;
    i00 += w;
    i01 -= w * tau;
    i11 += w * tau * tau;
  }
  const double det = i00 * i11 - i01 * i01;
  if (!(det > 0.0) || !std::isfinite(det)) return line;
  line.rho = rho;
  line.phi = phi;
  line.covariance << i11 / det, -i01 / det, -i01 / det, i00 / det;
  line.ok = true;
  return line;
}

}  // namespace waymark::laser_slam

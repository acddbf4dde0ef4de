#include "server/crossing/a_contrario.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace waymark::crossing {
namespace {

constexpr int kSample = 7;  // points that fix a fundamental matrix
constexpr int kRefit = 8;   // parameters of the least-squares refit (the 8-point system)
constexpr double kLn10 = 2.302585092994046;

double LineDistance(const cv::Vec3d& line, const cv::Point2f& p) {
  const double norm = std::hypot(line[0], line[1]);
  if (!(norm > 0)) return std::numeric_limits<double>::infinity();
  return std::abs(line[0] * p.x + line[1] * p.y + line[2]) / norm;
}

}  // namespace

double Log10Binomial(int n, int k) {
  if (k < 0 || k > n) return -std::numeric_limits<double>::infinity();
  return (std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0)) / kLn10;
}

std::vector<double> EpipolarResiduals(const cv::Matx33d& f,
                                      const std::vector<cv::Point2f>& query_points,
                                      const std::vector<cv::Point2f>& view_points) {
  std::vector<double> out;
  const size_t n = std::min(query_points.size(), view_points.size());
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Vec3d q(query_points[i].x, query_points[i].y, 1.0);
    const cv::Vec3d v(view_points[i].x, view_points[i].y, 1.0);
    const cv::Vec3d in_view = f * q;              // the query point's line in the view
    const cv::Vec3d in_query = f.t() * v;         // the view point's line in the query
    out.push_back(std::max(LineDistance(in_view, view_points[i]),
                           LineDistance(in_query, query_points[i])));
  }
  return out;
}

cv::Size MatchSupport(const std::vector<cv::Point2f>& points, cv::Size image) {
  const int min_w = std::max(1, image.width / 4), min_h = std::max(1, image.height / 4);
  if (points.empty()) return image;
  float x0 = points[0].x, x1 = x0, y0 = points[0].y, y1 = y0;
  for (const cv::Point2f& p : points) {
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  return cv::Size(std::clamp(static_cast<int>(std::ceil(x1 - x0)), min_w, std::max(min_w, image.width)),
                  std::clamp(static_cast<int>(std::ceil(y1 - y0)), min_h, std::max(min_h, image.height)));
}

EpipolarEvidence AContrarioEvidence(std::vector<double> residuals_px, cv::Size image,
                                    double tests) {
  EpipolarEvidence best;
  const int n = static_cast<int>(residuals_px.size());
  if (n <= kSample || image.width <= 0 || image.height <= 0 || !(tests >= 1)) return best;
  std::sort(residuals_px.begin(), residuals_px.end(),
            [](double a, double b) { return (std::isfinite(a) ? a : 1e300) <
                                            (std::isfinite(b) ? b : 1e300); });
  const double area = static_cast<double>(image.width) * image.height;
  const double diagonal = std::hypot(image.width, image.height);
  const double log_constant = std::log10(tests * 3.0 * (n - kSample));
  // A residual of 0 (a sample point itself) would give alpha = 0: a tenth of a pixel is the
  // keypoints' own precision at best.
  constexpr double kMinResidual = 0.1;
  for (int k = kRefit + 1; k <= n; ++k) {
    const double e = residuals_px[k - 1];
    if (!std::isfinite(e)) break;
    const double alpha = std::min(1.0, 2.0 * std::max(e, kMinResidual) * diagonal / area);
    // The model comes back refitted to all its inliers (least squares on the 8-point system):
    // 8 of the k residuals are fitted, not drawn, so only k - 8 count as evidence.
    const double log_nfa = log_constant + Log10Binomial(n, k) + Log10Binomial(k, kSample) +
                           (k - kRefit) * std::log10(alpha);
    if (log_nfa < best.log10_nfa) {
      best.log10_nfa = log_nfa;
      best.inliers = k;
      best.residual_px = e;
    }
  }
  return best;
}

}  // namespace waymark::crossing

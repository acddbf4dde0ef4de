#ifndef WAYMARK_SERVER_CROSSING_HUE_HISTOGRAM_H_
#define WAYMARK_SERVER_CROSSING_HUE_HISTOGRAM_H_

// The colour feature of METHODS.md section 1: a normalised histogram of HSI hue, compared with the
// Bhattacharyya distance.

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

namespace waymark::crossing {

// HSI hue in radians, [0, 2*pi), of one pixel:
//   H = arccos(((R-G) + (R-B)) / (2 sqrt((R-G)^2 + (R-B)(G-B)))),  H = 2*pi - H if B > G.
// std::nullopt for gray pixels (R = G = B), where hue is undefined.
std::optional<double> HsiHue(int r, int g, int b);

// Bin of a hue in [0, 2*pi) among `bins` equal bins. A hue exactly on a boundary (pure blue is
// 240 degrees, which arithmetic gives as 239.99999...) goes to the bin that starts there.
int HueBin(double hue, int bins);

// Normalised hue histogram (sums to 1) of a BGR 8-bit image over `bins` equal bins of [0, 2*pi).
// Gray pixels are left out; an image with no coloured pixel gives all zeros.
std::vector<float> HueHistogram(const cv::Mat& bgr, int bins);

// Bhattacharyya distance of two normalised histograms: sqrt(1 - sum_i sqrt(p_i q_i)), in [0, 1];
// 0 for identical histograms. Histograms of different sizes, or an all-zero one, give 1 (nothing
// in common), so a gray query never looks similar to anything.
double BhattacharyyaDistance(const std::vector<float>& p, const std::vector<float>& q);

// Similarity S = 1 - d of the paper.
inline double HueSimilarity(const std::vector<float>& p, const std::vector<float>& q) {
  return 1.0 - BhattacharyyaDistance(p, q);
}

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_HUE_HISTOGRAM_H_

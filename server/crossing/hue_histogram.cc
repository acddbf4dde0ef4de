#include "server/crossing/hue_histogram.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace waymark::crossing {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;

// Hue depends only on the differences R-G and G-B (each in [-255, 255]), so a 511x511 table of
// bin-independent hue angles replaces an arccos per pixel. Built once, on first use.
class HueTable {
 public:
  HueTable() {
    for (int rg = -255; rg <= 255; ++rg) {
      for (int gb = -255; gb <= 255; ++gb) {
        // Any (r, g, b) with these differences has the same hue; take b = 255 - max(0, ...) so all
        // three are in range.
        const int b = 255 - std::max({0, gb, gb + rg});
        const int g = b + gb;
        const int r = g + rg;
        const auto h = HsiHue(r, g, b);
        table_[Index(rg, gb)] = h ? *h : -1.0;
      }
    }
  }
  double Get(int rg, int gb) const { return table_[Index(rg, gb)]; }

 private:
  static int Index(int rg, int gb) { return (rg + 255) * 511 + (gb + 255); }
  std::array<double, 511 * 511> table_;  // 2 MB
};

const HueTable& Table() {
  static const HueTable* table = new HueTable();
  return *table;
}

}  // namespace

std::optional<double> HsiHue(int r, int g, int b) {
  if (r == g && g == b) return std::nullopt;
  const double rg = r - g, rb = r - b, gb = g - b;
  const double denominator = 2.0 * std::sqrt(rg * rg + rb * gb);
  if (denominator <= 0) return std::nullopt;
  // Rounding can push the cosine a hair outside [-1, 1].
  const double cosine = std::clamp((rg + rb) / denominator, -1.0, 1.0);
  double h = std::acos(cosine);
  if (b > g) h = kTwoPi - h;
  if (h >= kTwoPi) h -= kTwoPi;
  return h;
}

int HueBin(double hue, int bins) {
  const int bin = static_cast<int>(hue * bins / kTwoPi + 1e-9);
  return std::clamp(bin, 0, bins - 1);
}

std::vector<float> HueHistogram(const cv::Mat& bgr, int bins) {
  std::vector<float> hist(std::max(bins, 1), 0.0f);
  if (bgr.empty() || bgr.type() != CV_8UC3) return hist;
  const HueTable& table = Table();
  double counted = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const uchar* row = bgr.ptr<uchar>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const int b = row[3 * x], g = row[3 * x + 1], r = row[3 * x + 2];
      const double h = table.Get(r - g, g - b);
      if (h < 0) continue;
      hist[HueBin(h, bins)] += 1.0f;
      counted += 1;
    }
  }
  if (counted > 0) {
    for (float& v : hist) v = static_cast<float>(v / counted);
  }
  return hist;
}

double BhattacharyyaDistance(const std::vector<float>& p, const std::vector<float>& q) {
  if (p.size() != q.size() || p.empty()) return 1.0;
  double coefficient = 0, sum_p = 0, sum_q = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    coefficient += std::sqrt(std::max(0.0f, p[i]) * std::max(0.0f, q[i]));
    sum_p += p[i];
    sum_q += q[i];
  }
  if (sum_p <= 0 || sum_q <= 0) return 1.0;
  return std::sqrt(std::max(0.0, 1.0 - coefficient));
}

}  // namespace waymark::crossing

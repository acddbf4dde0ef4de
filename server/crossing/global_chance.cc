#include "server/crossing/global_chance.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace waymark::crossing {
namespace {

// Linear interpolation between order statistics (the sample quantile of type 7).
double Quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

// -ln(-ln q) for the Gumbel quantile x_q = mu - beta ln(-ln q).
double GumbelReduced(double q) { return -std::log(-std::log(q)); }

// A scale floor: a background of identical similarities would otherwise make any higher value
// infinitely unlikely.
constexpr double kMinScale = 1e-3;

// The scale fitted to a sample of n values is noisy, and a noisy scale makes the tail far out
// too thin as often as too fat, but the errors do not cancel: the false-accept rate grows as the
// sample shrinks (on Gumbel backgrounds, epsilon 0.01: 1.5 % at n = 300, 4.8 % at 30, 15.5 % at
// 10). The scale is therefore inflated by 1 + 0.5 / sqrt(n) + 6 / n, fitted by simulation
// (tests/crossing/global_chance_test.cc): the rate then stays within 0.5-2 x nominal for
// n = 15-300 at epsilon 0.1 and 0.01 (2.5 x at n = 10, epsilon 0.01).
constexpr double kScaleInflationSqrt = 0.5;
constexpr double kScaleInflationLinear = 6.0;

}  // namespace

double Log10GumbelTail(double x, double mu, double beta) {
  const double z = (x - mu) / beta;
  // P = 1 - exp(-t), t = exp(-z). Far in the tail t is tiny: P ~ t, log10 P = -z / ln 10.
  if (z > 30) return -z / std::log(10.0);
  const double t = std::exp(-z);
  const double p = -std::expm1(-t);
  return std::log10(std::max(p, 1e-300));
}

double NominalFalseAcceptRate(double max_log10_efa, int views) {
  if (views <= 0) return 0;
  const double per_view = std::min(1.0, std::pow(10.0, max_log10_efa) / views);
  return 1.0 - std::pow(1.0 - per_view, views);
}

GlobalChance EstimateGlobalChance(const std::vector<float>& similarity,
                                  const std::vector<int64_t>& place_of_slot,
                                  const GlobalChanceOptions& options) {
  GlobalChance g;
  const size_t n = std::min(similarity.size(), place_of_slot.size());
  bool any = false;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(similarity[i])) continue;
    ++g.views;
    if (!any || similarity[i] > g.best_similarity) {
      any = true;
      g.best_slot = static_cast<uint32_t>(i);
      g.best_similarity = similarity[i];
    }
  }
  if (!any) return g;
  g.best_place = place_of_slot[g.best_slot];
  std::vector<double> background;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(similarity[i]) || place_of_slot[i] == g.best_place) continue;
    background.push_back(similarity[i]);
  }
  g.background_views = static_cast<int>(background.size());
  if (options.place_maxima) {
    // Per other place its best view; the Gumbel law fitted to those maxima by moments.
    std::map<int64_t, double> best_of_place;
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(similarity[i]) || place_of_slot[i] == g.best_place) continue;
      auto [it, added] = best_of_place.emplace(place_of_slot[i], similarity[i]);
      if (!added) it->second = std::max<double>(it->second, similarity[i]);
    }
    const double m = static_cast<double>(best_of_place.size());
    if (best_of_place.size() < 4) return g;
    double sum = 0, sum2 = 0;
    for (const auto& [place, s] : best_of_place) sum += s;
    const double mean = sum / m;
    for (const auto& [place, s] : best_of_place) sum2 += (s - mean) * (s - mean);
    const double sd = std::sqrt(sum2 / (m - 1));
    constexpr double kEulerGamma = 0.5772156649015329;
    g.beta = std::max(sd * std::sqrt(6.0) / M_PI, kMinScale) *
             (1.0 + kScaleInflationSqrt / std::sqrt(m) + kScaleInflationLinear / m);
    g.mu = mean - kEulerGamma * g.beta;
    g.log10_tail = Log10GumbelTail(g.best_similarity, g.mu, g.beta);
    g.log10_efa = std::log10(m + 1) + g.log10_tail;  // every place, the best one included
    g.computed = true;
    return g;
  }
  if (g.background_views < std::max(2, options.min_background_views)) return g;
  std::sort(background.begin(), background.end());
  const double lo = std::clamp(options.low_quantile, 0.01, 0.98);
  const double hi = std::clamp(options.high_quantile, lo + 0.01, 0.99);
  const double q_lo = Quantile(background, lo);
  const double q_hi = Quantile(background, hi);
  const double m = static_cast<double>(background.size());
  g.beta = std::max((q_hi - q_lo) / (GumbelReduced(hi) - GumbelReduced(lo)), kMinScale) *
           (1.0 + kScaleInflationSqrt / std::sqrt(m) + kScaleInflationLinear / m);
  g.mu = q_lo - g.beta * GumbelReduced(lo);
  g.log10_tail = Log10GumbelTail(g.best_similarity, g.mu, g.beta);
  g.log10_efa = std::log10(static_cast<double>(g.views)) + g.log10_tail;
  g.computed = true;
  return g;
}

}  // namespace waymark::crossing

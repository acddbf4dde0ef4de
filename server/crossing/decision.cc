#include "server/crossing/decision.h"

#include <algorithm>

namespace waymark::crossing {

std::vector<double> DecisionValues(const std::vector<double>& matches,
                                   const std::vector<double>& similarities, double alpha,
                                   double beta) {
  const size_t n = std::min(matches.size(), similarities.size());
  double m_max = 0;
  double s_max = 0;
  for (size_t i = 0; i < n; ++i) {
    m_max = std::max(m_max, matches[i]);
    s_max = std::max(s_max, similarities[i]);
  }
  std::vector<double> des(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    if (m_max > 0) des[i] += alpha * matches[i] / m_max;
    if (s_max > 0) des[i] += beta * similarities[i] / s_max;
  }
  return des;
}

int ArgMax(const std::vector<double>& values) {
  int best = -1;
  for (size_t i = 0; i < values.size(); ++i) {
    if (best < 0 || values[i] > values[best]) best = static_cast<int>(i);
  }
  return best;
}

int AssignCluster(const std::vector<int>& matches_per_center, int threshold) {
  int best = -1;
  for (size_t i = 0; i < matches_per_center.size(); ++i) {
    if (best < 0 || matches_per_center[i] > matches_per_center[best]) best = static_cast<int>(i);
  }
  if (best < 0 || matches_per_center[best] < threshold) return -1;
  return best;
}

}  // namespace waymark::crossing

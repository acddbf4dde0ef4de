#include "server/visual_slam/geometry/sequential_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace waymark::visual_slam {
namespace {

// SplitMix64: tiny, and unlike std:: distributions gives the same numbers everywhere.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, n); the modulo bias is negligible for the small n used here.
  int Below(int n) { return static_cast<int>(Next() % static_cast<uint64_t>(n)); }

 private:
  uint64_t state_;
};

size_t SharedCount(const std::vector<int>& a, const std::vector<int>& b) {  // both sorted
  size_t shared = 0;
  auto i = a.begin(), j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++shared, ++i, ++j;
    }
  }
  return shared;
}

// Whether a ranks above b: lower MSAC cost when both are scored, else more inliers.
bool Better(const Hypothesis& a, const Hypothesis& b) {
  if (std::isfinite(a.cost) && std::isfinite(b.cost)) return a.cost < b.cost;
  return a.inliers.size() > b.inliers.size();
}

bool SameMotion(const Hypothesis& a, const Hypothesis& b) {
  const size_t smaller = std::min(a.inliers.size(), b.inliers.size());
  return 2 * SharedCount(a.inliers, b.inliers) > smaller;
}

double RotationAngle(const Eigen::Matrix3d& R) {
  const double c = 0.5 * (R.trace() - 1.0);
  return std::acos(std::min(1.0, std::max(-1.0, c)));
}

Eigen::Vector3d Direction(const Eigen::Vector3d& t) {
  const double n = t.norm();
  return n > 1e-12 ? Eigen::Vector3d(t / n) : Eigen::Vector3d::Zero();
}

// Positions 0..n-1 ordered by eta, descending; ties keep their order in `previous`.
std::vector<int> Rank(const std::vector<double>& eta, std::vector<int> previous) {
  std::stable_sort(previous.begin(), previous.end(),
                   [&eta](int a, int b) { return eta[a] > eta[b]; });
  return previous;
}

// Sample j of a round over `pool` (positions in eta order), PROSAC-like (see the header).
std::vector<int> DrawSample(const std::vector<int>& pool, int m, int j, int per_round, Rng* rng) {
  const int s = static_cast<int>(pool.size());
  if (j == 0 || s == m) return std::vector<int>(pool.begin(), pool.begin() + m);
  // Prefix n_j grows linearly from m (+1 after sample 0) to s at the last sample.
  const int steps = std::max(1, per_round - 1);
  const int n = std::min(
      s, m + std::max(1, static_cast<int>((static_cast<int64_t>(s - m) * j + steps - 1) / steps)));
  std::vector<int> sample = {pool[n - 1]};
  // m - 1 distinct picks among the first n - 1 (partial Fisher-Yates over their indices).
  std::vector<int> idx(n - 1);
  std::iota(idx.begin(), idx.end(), 0);
  for (int k = 0; k < m - 1; ++k) {
    const int pick = k + rng->Below(n - 1 - k);
    std::swap(idx[k], idx[pick]);
    sample.push_back(pool[idx[k]]);
  }
  return sample;
}

// The hypothesis of `motion` with its inliers among `candidates`; `msac` (optional) receives the
// truncated squared error sum_i min(e_i, threshold)^2, which ranks polished motions better than a
// count (a polish that drops an outlier lowers the count but also the error).
Hypothesis Score(const MotionSolver& solver, const Motion& motion,
                 const std::vector<int>& candidates, double threshold_px, double* msac = nullptr) {
  Hypothesis h{motion, {}};
  double total = 0;
  std::vector<double> errors;
  solver.ErrorsPx(motion, candidates, &errors);
  for (size_t k = 0; k < candidates.size(); ++k) {
    const int c = candidates[k];
    const double e = c >= 0 ? errors[k] : std::numeric_limits<double>::infinity();
    if (e <= threshold_px) h.inliers.push_back(c);
    const double capped = std::min(e, threshold_px);
    total += capped * capped;
  }
  // MSAC ranking only for directions-only (monocular) solvers; see the header.
  if (solver.UnitTranslation()) h.cost = total;
  if (msac) *msac = total;
  std::sort(h.inliers.begin(), h.inliers.end());
  h.inliers.erase(std::unique(h.inliers.begin(), h.inliers.end()), h.inliers.end());
  return h;
}

}  // namespace

double MotionDifference(const Motion& a, const Motion& b, double lambda1, double lambda2) {
  return lambda1 * RotationAngle(a.R.transpose() * b.R) + lambda2 * (a.t - b.t).norm();
}

bool KeepHypothesis(Hypothesis h, std::vector<Hypothesis>* best) {
  if (h.inliers.empty()) return false;
  for (size_t k = 0; k < best->size(); ++k) {
    if (!SameMotion((*best)[k], h)) continue;
    if (!Better(h, (*best)[k])) return false;
    best->erase(best->begin() + k);  // replaced by the better version of the same motion
    break;
  }
  size_t pos = 0;
  while (pos < best->size() && !Better(h, (*best)[pos])) ++pos;
  if (pos >= 3) return false;
  best->insert(best->begin() + pos, std::move(h));
  if (best->size() > 3) best->resize(3);
  return true;
}

int ReferenceHypothesis(const std::vector<Hypothesis>& best, const std::vector<int>& sample) {
  std::vector<int> sorted = sample;
  std::sort(sorted.begin(), sorted.end());
  int chosen = -1;
  size_t most = 0;
  for (size_t k = 0; k < best.size(); ++k) {
    const size_t shared = SharedCount(sorted, best[k].inliers);
    if (2 * shared >= sorted.size() && shared > most) chosen = static_cast<int>(k), most = shared;
  }
  return chosen;
}

void UpdateEta(const std::vector<int>& sample, const std::vector<int>& reference, double b1,
               double b2, std::vector<double>* eta) {
  const int n = static_cast<int>(eta->size());
  std::vector<char> in_sample(n, 0), in_reference(n, 0);
  for (int p : sample)
    if (p >= 0 && p < n) in_sample[p] = 1;
  for (int p : reference)
    if (p >= 0 && p < n) in_reference[p] = 1;
  for (int p = 0; p < n; ++p) {
    double& e = (*eta)[p];
    if (in_sample[p] && in_reference[p]) {
      e += b1;
    } else if (in_reference[p]) {
      e += b2;
    } else if (in_sample[p]) {
      e -= b1;
    }
    e = std::min(1.0, std::max(0.0, e));
  }
}

SamplerResult SequentialSample(const MotionSolver& solver, const std::vector<int>& candidates,
                               const std::vector<double>& initial_eta,
                               const std::optional<Motion>& predicted, double inlier_threshold_px,
                               const SamplerOptions& options) {
  SamplerResult result;
  const int n = static_cast<int>(candidates.size());
  result.eta.resize(n);
  for (int k = 0; k < n; ++k) {
    const double e = k < static_cast<int>(initial_eta.size()) ? initial_eta[k] : 0.5;
    result.eta[k] = std::isfinite(e) ? std::min(1.0, std::max(0.0, e)) : 0.5;
  }
  const int m = solver.SampleSize();
  const int per_round = options.hypotheses_per_round;
  if (m <= 0 || n < m || per_round <= 0) return result;

  // Correspondence index -> candidate position, for eq 10 on positions.
  int max_index = -1;
  for (int c : candidates) max_index = std::max(max_index, c);
  std::vector<int> position(max_index + 1, -1);
  std::vector<char> samplable(n, 0);
  for (int k = 0; k < n; ++k) {
    if (candidates[k] >= 0) position[candidates[k]] = k;
    samplable[k] = candidates[k] >= 0 && solver.Samplable(candidates[k]);
  }

  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  order = Rank(result.eta, order);
  Rng rng(options.seed);
  const int max_rounds = std::max(1, options.max_rounds);
  for (int round = 0; round < max_rounds; ++round) {
    bool eta_updated = false;
    std::vector<int> pool;
    for (int p : order)
      if (samplable[p]) pool.push_back(p);
    if (static_cast<int>(pool.size()) < m) break;
    // The pairs M1 does not explain, in eta order: every other sample of the round comes from
    // them, so that a competing motion (or the true one, when M1 is wrong) gets pure samples.
    std::vector<int> residual;
    if (!result.best.empty()) {
      const std::vector<int>& m1 = result.best[0].inliers;
      for (int p : pool)
        if (!std::binary_search(m1.begin(), m1.end(), candidates[p])) residual.push_back(p);
    }
    const bool split = static_cast<int>(residual.size()) >= m && per_round >= 2;
    const int main_count = split ? (per_round + 1) / 2 : per_round;
    for (int j = 0; j < per_round; ++j) {
      const std::vector<int> sample_pos =
          split && j % 2 == 1 ? DrawSample(residual, m, j / 2, per_round / 2, &rng)
                              : DrawSample(pool, m, split ? j / 2 : j, main_count, &rng);
      std::vector<int> sample;
      for (int p : sample_pos) sample.push_back(candidates[p]);
      std::sort(sample.begin(), sample.end());
      bool any_model = false;
      for (const Motion& motion : solver.Solve(sample)) {
        if (!motion.R.allFinite() || !motion.t.allFinite()) continue;
        any_model = true;
        ++result.hypotheses;
        KeepHypothesis(Score(solver, motion, candidates, inlier_threshold_px), &result.best);
      }
      if (!any_model) continue;
      const int ref = ReferenceHypothesis(result.best, sample);
      if (ref < 0) continue;
      std::vector<int> reference;
      for (int c : result.best[ref].inliers) reference.push_back(position[c]);
      UpdateEta(sample_pos, reference, options.b1, options.b2, &result.eta);
      eta_updated = true;
    }
    ++result.rounds;
    std::vector<int> reranked = Rank(result.eta, order);
    // A round in which no sample belonged to a kept hypothesis learned nothing: its unchanged
    // ranking is not convergence, so sampling goes on (with new random draws).
    if (eta_updated && reranked == order) break;
    order = std::move(reranked);
  }
  if (result.best.empty()) return result;

  // Polish M1..M3 on their inliers, then rank them again.
  std::vector<Hypothesis> polished;
  for (Hypothesis& h : result.best) {
    double msac = 0;
    Score(solver, h.motion, candidates, inlier_threshold_px, &msac);
    for (int pass = 0; pass < 3; ++pass) {
      const std::optional<Motion> refined = solver.Refine(h.motion, h.inliers);
      if (!refined || !refined->R.allFinite() || !refined->t.allFinite()) break;
      double refined_msac = 0;
      Hypothesis better = Score(solver, *refined, candidates, inlier_threshold_px, &refined_msac);
      if (!(refined_msac < msac)) break;
      const bool same_inliers = better.inliers == h.inliers;
      h = std::move(better);
      msac = refined_msac;
      if (same_inliers) break;
    }
    KeepHypothesis(std::move(h), &polished);
  }
  result.best = std::move(polished);

  // eq 12: of the hypotheses with enough support, the one closest to the predicted motion.
  result.chosen = 0;
  if (!predicted) return result;
  Motion reference = *predicted;
  const bool unit = solver.UnitTranslation();
  if (unit) reference.t = Direction(reference.t);
  const double needed = options.tie_break_fraction * result.best[0].inliers.size();
  double least = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < result.best.size(); ++k) {
    if (result.best[k].inliers.size() < needed) continue;
    Motion candidate = result.best[k].motion;
    if (unit) candidate.t = Direction(candidate.t);
    const double diff = MotionDifference(candidate, reference, options.lambda1, options.lambda2);
    if (diff < least) least = diff, result.chosen = static_cast<int>(k);
  }
  return result;
}

}  // namespace waymark::visual_slam

#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_SEQUENTIAL_SAMPLER_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_SEQUENTIAL_SAMPLER_H_

// Sequential sampling of a motion model (eq 10-12, METHODS.md section 3): the pairs are ranked by
// an inlier probability eta and sampled in that order (PROSAC-like), the three best hypotheses
// M1..M3 are kept, eta is raised or lowered by how each sample agrees with them (eq 10), the pairs
// are re-ranked and sampled again until the ranking stops changing, and of M1..M3 the one closest
// to the previous frame's motion wins (eq 12).
//
// Where the paper is vague, we decided (and the tests pin down):
// - Sampling inside a round: the samplable candidates in eta order form the pool; sample j takes
//   the pool's element n_j - 1 plus SampleSize() - 1 distinct random elements of the first
//   n_j - 1, with the prefix n_j growing linearly from SampleSize() (sample 0 is the top
//   SampleSize() pairs) to the whole pool at the round's last sample. So every round starts with
//   the most probable pairs and still reaches all of them. Once a hypothesis is kept, every other
//   sample of a round is drawn the same way from the pairs outside M1's inliers (the residual,
//   in eta order): the eta ranking favours M1's pairs, and without this a competing motion of
//   similar support would almost never get a pure sample of 8 and never reach M2 (eq 12 would
//   have nothing to choose from); when M1 is wrong, the residual holds the true inliers. The
//   generator is a SplitMix64 seeded with options.seed: the same inputs give the same result on
//   every platform.
// - Ranking (MSAC, not the paper's count): a hypothesis is better than another when its
//   truncated squared error sum_i min(e_i, threshold)^2 over all candidates is lower (when
//   either is unscored, cost +inf, the larger inlier count wins). Why: on KITTI 06 (car driving
//   straight) far points with no parallax fit almost any small motion within 2 px, so a wrong
//   motion (4-6 deg rotation, sideways t) had ~300 of ~320 pairs as inliers, as many as the
//   right one; the count preferred it and, being the "same motion" by inlier overlap, it also
//   hid the right one from M1..M3. The right motion puts the near points' errors well below
//   the threshold, which the truncated squared error sees and the count does not. Measured on
//   KITTI 06 frames 0-50 with 5-pair samples (waymark-vo-bench, 5 seeds, ATE median): count
//   4.09 m (none) / 6.69 m (full:yolo), MSAC 2.81 / 4.92 m. Only for
//   solvers with unit translations (monocular): with depth (PnP) the far-point ambiguity does
//   not arise, and MSAC ranking there cost accuracy on the Bonn crowd window (full:yolo ATE
//   median 0.035 -> 0.037 m, max 0.044 -> 0.052 m, 5 seeds), so PnP keeps the paper's count.
// - "Distinct" hypotheses (KeepHypothesis): two hypotheses are the same motion when their inlier
//   sets share more than half of the smaller one. A new hypothesis that is the same motion as a
//   kept one replaces it only if it is better (above). Otherwise it enters at its rank, the ones
//   below shift down and the fourth is dropped. Without this the three
//   best would be three copies of the dominant motion and eq 12 would have nothing to choose
//   from (a person walking across the whole frame is a second motion of similar support).
// - Which I of eq 10 ("I = I_k if I_k in I*"; ReferenceHypothesis): after each sample I*, the kept
//   hypothesis the sample belongs to: the one holding the most pairs of the sample, and at least
//   half of them (ties: the better-ranked). When no kept hypothesis holds half of the sample,
//   eta is not changed. The update runs after every sample (not only when M* entered the three
//   best): this is what lets eq 10's third rule (-b1 for sample pairs outside I) push the
//   outliers of contaminated samples down the ranking.
// - eta is clamped to [0, 1]. Ranking ties keep the previous order (stable sort), so a round
//   that changes no eta enough to swap two pairs ends the loop. A round in which no sample
//   belonged to a kept hypothesis (eta untouched, typically only contaminated samples so far)
//   does not end it: nothing was learned, and the next round draws new samples.
// - Before eq 12 each of M1..M3 is polished with MotionSolver::Refine on its inliers and its
//   inliers found again (three times at most, or until they stop changing); a polish is kept
//   only when it lowers the truncated squared error sum_i min(e_i, threshold)^2 over all
//   candidates (MSAC). The three are then re-ranked by the rules above (two that converged to
//   the same motion merge).
// - eq 12 only among hypotheses with at least tie_break_fraction of M1's inliers; without a
//   predicted motion M1 wins. For solvers with unit-norm translations (monocular) both
//   translations are normalized before comparing (directions only).

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "server/visual_slam/options.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// A minimal solver for the sampler.
class MotionSolver {
 public:
  virtual ~MotionSolver() = default;
  virtual int SampleSize() const = 0;
  // Whether correspondence i may be part of a sample (PnP: it needs reference_point).
  virtual bool Samplable(int i) const { return true; }
  // Zero or more candidate motions (reference -> current, X_c = R X_r + t) from the sample.
  virtual std::vector<Motion> Solve(const std::vector<int>& sample) const = 0;
  // Error of correspondence i under `motion`, in pixels (normalized error * focal_px); +inf if
  // undefined (also for an index out of range).
  virtual double ErrorPx(const Motion& motion, int i) const = 0;
  // ErrorPx of each of `indices` (same order) into `errors`; solvers override it to set up a
  // motion once for all pairs (the sampler scores every hypothesis on every candidate).
  virtual void ErrorsPx(const Motion& motion, const std::vector<int>& indices,
                        std::vector<double>* errors) const {
    errors->resize(indices.size());
    for (size_t k = 0; k < indices.size(); ++k) (*errors)[k] = ErrorPx(motion, indices[k]);
  }
  // Optional polish of a hypothesis on all its inliers (least squares); nullopt = keep it as is.
  // The sampler polishes M1..M3 before eq 12 (a motion from a minimal sample is noisy enough to
  // miss a few percent of the true inliers).
  virtual std::optional<Motion> Refine(const Motion& motion,
                                       const std::vector<int>& inliers) const {
    return std::nullopt;
  }
  // True when the solver's translations are directions only (|t| = 1, monocular): eq 12 then
  // compares translation directions.
  virtual bool UnitTranslation() const { return false; }
};

struct Hypothesis {
  Motion motion;
  std::vector<int> inliers;  // correspondence indices, sorted ascending
  // MSAC score: sum over all candidates of min(error, threshold)^2 [px^2]; lower is better.
  // +inf = not scored (PnP, or made by hand): then the inlier count ranks (KeepHypothesis).
  double cost = std::numeric_limits<double>::infinity();
};

struct SamplerResult {
  std::vector<Hypothesis> best;  // up to 3 (M1..M3), best (lowest MSAC cost) first
  int chosen = -1;               // index into best after the eq 12 tie-break; -1 = none found
  int rounds = 0;                // eq 10-11 re-rankings done
  int hypotheses = 0;            // models evaluated
  std::vector<double> eta;  // final inlier probability per candidate (same order as candidates)
};

// eq 10-12. `candidates`: indices of correspondences that may be sampled (the pipeline passes the
// not-potentially-dynamic pairs); `initial_eta[k]` the prior inlier probability of candidates[k]
// (the pipeline passes 1 - hamming/delta; missing or non-finite values count as 0.5, others are
// clamped to [0, 1]). Inliers are counted over ALL candidates (error <= inlier_threshold_px).
// `predicted`: the motion predicted from the previous frame (constant velocity), used by eq 12;
// none = pick M1. Deterministic for a given options.seed. Fewer samplable candidates than the
// sample size, or no model from any sample: an empty `best` and chosen = -1.
SamplerResult SequentialSample(const MotionSolver& solver, const std::vector<int>& candidates,
                               const std::vector<double>& initial_eta,
                               const std::optional<Motion>& predicted, double inlier_threshold_px,
                               const SamplerOptions& options);

// eq 12: lambda1 * angle(R_a^-1 R_b) [rad] + lambda2 * |t_a - t_b|.
double MotionDifference(const Motion& a, const Motion& b, double lambda1, double lambda2);

// The steps of SequentialSample, exposed for tests.

// Offers `h` to the kept list `best` (best first: lowest cost, or most inliers when unscored; at
// most 3, distinct motions as described above). Returns whether it entered.
bool KeepHypothesis(Hypothesis h, std::vector<Hypothesis>* best);

// The index into `best` of the hypothesis a sample (correspondence indices) belongs to, or -1.
int ReferenceHypothesis(const std::vector<Hypothesis>& best, const std::vector<int>& sample);

// eq 10 on candidate positions: `sample` is I*, `reference` is I (positions into eta, any order).
// In I* and in I: +b1; in I only: +b2; in I* only: -b1; clamped to [0, 1].
void UpdateEta(const std::vector<int>& sample, const std::vector<int>& reference, double b1,
               double b2, std::vector<double>* eta);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_SEQUENTIAL_SAMPLER_H_

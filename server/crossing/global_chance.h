#ifndef WAYMARK_SERVER_CROSSING_GLOBAL_CHANCE_H_
#define WAYMARK_SERVER_CROSSING_GLOBAL_CHANCE_H_

// The chance model of the retrieval mode's global path (issue 34): how high would the best global
// similarity of a query run if its place were not in the database?
//
// The database is its own background. For one query, the similarities to the views of every place
// except the best one are (almost all) similarities to places the query does not show. Their
// upper tail is modelled by a Gumbel law fitted to their lower and upper quartiles (robust: the
// few views of neighbouring places that do look alike sit above the upper quartile and barely
// move the fit):
//
//   P(s >= x) = 1 - exp(-exp(-(x - mu) / beta)),   beta = (q75 - q25) / 1.5725 * c(n),
//                                                   mu = q25 + beta * ln(-ln 0.25)
//
// with c(n) = 1 + 0.5 / sqrt(n) + 6 / n for n background views: a small-sample inflation of the
// scale (a noisy fitted scale makes the far tail too thin more often than it averages out;
// fitted by simulation, global_chance.cc).
//
// The Gumbel law is the limit law of maxima; its tail is exponential, heavier than the Gaussian
// tail that failed as a chance model for the same similarities (docs/results.md, issue 18).
// The expected number of false alarms of the best view is then
//
//   EFA = views * P(s >= s_best)
//
// (every view of the database could have been the best one by chance). Under the model, a query
// of a place that is not in the database gets EFA < epsilon with probability
// 1 - (1 - epsilon / views)^views ~ 1 - exp(-epsilon): that is the nominal false-accept rate
// of the global path. The threshold epsilon is RecognitionOptions::max_log10_global_efa.
//
// With fewer than `min_background_views` views outside the best place the quartiles say nothing
// of a tail: the model is not computed and the global path cannot accept (the geometric NFA still
// can; evidence over a stream still gets the similarity through PlaceEvidenceFilter).

#include <cstdint>
#include <vector>

namespace waymark::crossing {

struct GlobalChanceOptions {
  // Views of other places the fit needs (ours; below it the quartiles of a handful of values
  // say nothing of a tail).
  int min_background_views = 8;
  // The two quantiles of the background the Gumbel law is fitted to (ours: the quartiles; the
  // upper one stays below the few views of neighbouring places that do look alike).
  double low_quantile = 0.25;
  double high_quantile = 0.75;
  // An alternative background, for the held-out evaluation (bench/crossing/vpr_heldout.cc), not the
  // default: per other place the query's best similarity over its views (a maximum already),
  // a Gumbel law fitted to those maxima by moments (scale inflated as above, n = places), and
  // EFA = places x P(max >= s_best). Measured worse on both counts (docs/crossing-recognition.md,
  // "Acceptance"): farther from nominal on the rotation set's unknown places, no recall gained.
  bool place_maxima = false;
};

struct GlobalChance {
  bool computed = false;      // false: too few background views (or no similarities)
  uint32_t best_slot = 0;     // the most similar view
  int64_t best_place = -1;    // its place
  double best_similarity = 0;
  int views = 0;              // views scored (the tests)
  int background_views = 0;   // views of the other places the law was fitted on
  double mu = 0;              // Gumbel location of the fit
  double beta = 0;            // Gumbel scale of the fit
  double log10_tail = 0;      // log10 P(an unrelated view is at least as similar)
  double log10_efa = 0;       // log10 of views x tail: the expected false alarms
};

// `similarity` per slot (global_index.h: cosine), `place_of_slot` the place (crossing id) of each
// slot; both the same length. Slots with a non-finite similarity are left out.
GlobalChance EstimateGlobalChance(const std::vector<float>& similarity,
                                  const std::vector<int64_t>& place_of_slot,
                                  const GlobalChanceOptions& options = {});

// log10 of the Gumbel upper tail P(X >= x) for location mu and scale beta (> 0), accurate far out
// in the tail (no 1 - 1 cancellation).
double Log10GumbelTail(double x, double mu, double beta);

// The false-accept rate the rule "EFA < 10^max_log10_efa" has on queries of unknown places when
// the model holds: 1 - (1 - epsilon / views)^views.
double NominalFalseAcceptRate(double max_log10_efa, int views);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_GLOBAL_CHANCE_H_

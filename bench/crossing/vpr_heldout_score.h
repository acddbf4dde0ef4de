#ifndef WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SCORE_H_
#define WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SCORE_H_

// Scoring of the held-out-places evaluation (waymark-vpr-heldout): each query's two pieces of
// evidence, recorded once (the geometric NFA path's answer, and the global path's best place with
// its chance model's expected false alarms), replayed for any global threshold epsilon, and the
// leave-one-set-out calibration of epsilon.

#include <map>
#include <string>
#include <vector>

namespace waymark::vpr {

struct HeldOutRow {
  std::string set;        // "corridor", "triplets", "kitti", "bonn", "rotation"
  bool unknown_variant = false;  // from the set's unknown-places variant
  bool known = true;      // the query's place is in the database
  // Today's rule (the legacy lift 0.16, global path before the NFA), same run.
  bool today_recognized = false;
  bool today_correct = false;
  // The NFA path alone (max_log10_nfa 0).
  bool nfa_recognized = false;
  bool nfa_correct = false;
  double log10_nfa = 0;
  bool nfa_computed = false;
  // The global path: its best view's place and the chance model.
  bool global_computed = false;
  bool global_correct = false;
  double global_log10_efa = 0;
  double global_similarity = 0;
  // The same under each chance-model variant of kModels (NaN: not computed), for calibration.
  std::vector<double> efa_by_model;
  std::string protocol;
};

// Chance-model variants the calibration chooses among: the quantile pair of the Gumbel fit.
struct ModelVariant {
  const char* name;
  double low_quantile;
  double high_quantile;
  bool place_maxima = false;  // GlobalChanceOptions::place_maxima (the quantiles then unused)
};
inline constexpr ModelVariant kModels[] = {
    {"quartiles (0.25, 0.75)", 0.25, 0.75},
    {"lower half (0.10, 0.50)", 0.10, 0.50},
    {"upper half (0.50, 0.90)", 0.50, 0.90},
    {"place maxima (moments)", 0, 0, true},
};

// The rule of the engine (recognizer.cc), replayed: the NFA's answer when it accepts, else the
// global path's when its EFA < 10^max_log10_global_efa.
struct Replayed {
  bool recognized = false;
  bool correct = false;
};
Replayed Replay(const HeldOutRow& row, double max_log10_global_efa, int model = 0);
Replayed Today(const HeldOutRow& row);

struct SetScore {
  int known = 0, correct = 0, wrong = 0, refused = 0;  // known queries of the known variant
  int unknown = 0, false_accepts = 0;                  // unknown queries of the unknown variant
  double recall() const { return known ? static_cast<double>(correct) / known : 0; }
  double false_accept_rate() const {
    return unknown ? static_cast<double>(false_accepts) / unknown : 0;
  }
};
// Per set, under the rule `rule`.
template <typename Rule>
std::map<std::string, SetScore> Score(const std::vector<HeldOutRow>& rows, Rule rule) {
  std::map<std::string, SetScore> out;
  for (const HeldOutRow& r : rows) {
    SetScore& s = out[r.set];
    const Replayed a = rule(r);
    if (!r.unknown_variant && r.known) {
      ++s.known;
      if (a.recognized && a.correct) ++s.correct;
      if (a.recognized && !a.correct) ++s.wrong;
      if (!a.recognized) ++s.refused;
    } else if (r.unknown_variant && !r.known) {
      ++s.unknown;
      if (a.recognized) ++s.false_accepts;
    }
  }
  return out;
}

// Leave one set out: for each set L, the model variant and epsilon of `grid` chosen on the other
// sets (false accepts
// <= max_false_accept on every other set's unknown variant, then the highest mean recall over
// them; ties to the stricter epsilon), and L's score at it.
struct LeaveOneOut {
  std::string left_out;
  double chosen_log10_efa = 0;
  int chosen_model = 0;
  bool feasible = true;  // some epsilon met the ceiling on the calibration sets
  SetScore held_out;     // the left-out set at the chosen epsilon
};
std::vector<LeaveOneOut> LeaveOneSetOut(const std::vector<HeldOutRow>& rows,
                                        const std::vector<double>& grid, double max_false_accept);

}  // namespace waymark::vpr

#endif  // WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SCORE_H_

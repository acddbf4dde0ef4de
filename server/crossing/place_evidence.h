#ifndef WAYMARK_SERVER_CROSSING_PLACE_EVIDENCE_H_
#define WAYMARK_SERVER_CROSSING_PLACE_EVIDENCE_H_

// Evidence over frames (issue 18): a robot approaching a crossing sends many frames, none of which
// may be conclusive alone. A discrete Bayes filter over "the robot is at crossing c" for every
// crossing that has appeared in a frame's candidates, plus "somewhere not in the database":
//
//   predict:  P(c) <- (1 - switch) P(c) + switch / (places + 1)   (the robot may move on)
//   update:   P(c) <- P(c) * LR_c, normalised
//
// where LR_c, the likelihood ratio of the frame's evidence for c against chance, is 1 / NFA of
// c's best candidate view (a_contrario.h: the NFA is the number of views chance would match as
// well, so 1 / NFA is how much likelier the match is at c than by chance), capped at
// max_log10_ratio so that one frame cannot overrule everything, and 10^miss_log10_ratio for a
// crossing without a candidate in the frame (or with one chance explains). A crossing is recognized once its posterior passes
// the threshold.

#include <cstdint>
#include <map>
#include <vector>

#include "absl/status/status.h"

namespace waymark::crossing {

struct EvidenceOptions {
  // Posterior a crossing needs to be recognized. (StreamRecognize with threshold 0 runs no
  // filter: every frame decides on its own, the paper's loop.)
  double threshold = 0.95;
  // Chance per frame that the robot moved to another place (ours: at 5-10 frames per second a
  // robot stays at a crossing for seconds; 0.05 lets a wrong belief fade within a few frames).
  double switch_probability = 0.05;
  // One frame's likelihood ratio at most 10^max_log10_ratio (ours: 10^2, so that two agreeing
  // frames decide and a single one does not: from the prior, one frame at the cap reaches 0.72,
  // a second 0.99).
  double max_log10_ratio = 2.0;
  // Likelihood ratio of a frame that has no candidate view of a crossing, for that crossing (ours:
  // 10^-0.5, about 0.3: at a crossing about one frame in three misses it, to blur, occlusion or
  // a view between the enrolled ones). Frames that match nothing thus move the belief towards
  // "somewhere not in the database".
  double miss_log10_ratio = -0.5;
};

absl::Status ValidateEvidenceOptions(const EvidenceOptions& options);

// What one frame said of one crossing: the log10 NFA of its best candidate view.
struct FrameEvidence {
  int64_t crossing_id = 0;
  double log10_nfa = 0;
};

// A frame whose answer the retrieval mode's global path accepted (Recognition::
// accepted_by_global) has no NFA to give; it counts for its crossing as much as one frame can
// (LR 10^max_log10_ratio): its false accepts were measured at most 3 % per frame, and one frame
// still does not decide alone.
inline FrameEvidence GlobalAnswerEvidence(int64_t crossing_id, const EvidenceOptions& options) {
  return {crossing_id, -options.max_log10_ratio};
}

// What one frame's global path says of the crossing of its most similar view (issue 34): the
// chance model's expected false alarms (global_chance.h) stand for the NFA, so the likelihood
// ratio is 1 / EFA, clamped as every frame's. A frame the global path accepted alone
// (EFA < 10^max_log10_global_efa = 10^-2) counts at the cap; a weak frame (EFA between that and
// 1) is not accepted alone but counts here, so that agreeing weak frames decide over a stream;
// a frame chance explains (EFA >= 1) counts as a miss.
inline FrameEvidence GlobalFrameEvidence(int64_t crossing_id, double log10_false_alarms) {
  return {crossing_id, log10_false_alarms};
}

struct PlaceBelief {
  int64_t crossing_id = -1;  // the most probable crossing (-1: none seen yet)
  double posterior = 0;      // its probability
  double unknown = 1;        // probability that the robot is at no enrolled crossing
  int frames = 0;            // frames integrated
  int frames_since_change = 0;  // frames since the most probable crossing last changed
  bool recognized = false;   // posterior >= threshold
};

class PlaceEvidenceFilter {
 public:
  explicit PlaceEvidenceFilter(const EvidenceOptions& options = {}) : options_(options) {}

  // Integrates one frame: `evidence` has at most one entry per crossing (the best is kept if
  // not). A frame without candidates is evidence too: nothing matched, which moves no belief
  // but the prediction's.
  const PlaceBelief& Update(const std::vector<FrameEvidence>& evidence);
  const PlaceBelief& belief() const { return belief_; }
  const EvidenceOptions& options() const { return options_; }
  // The posterior of `crossing_id` (0 if never seen).
  double Posterior(int64_t crossing_id) const;
  void Reset();

 private:
  EvidenceOptions options_;
  std::map<int64_t, double> posterior_;  // by crossing id
  double unknown_ = 1.0;
  PlaceBelief belief_;
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_PLACE_EVIDENCE_H_
